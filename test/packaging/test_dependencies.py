"""The dependency table, package.xml and CMake agree, and name the right Debian packages.

scripts/debian-dependencies.txt is what scripts/install_deps.sh installs on a new
machine. A dependency forgotten there builds fine on a machine where someone
installed it by hand and breaks for every user, so these tests check the table
against what the build declares (package.xml), what it looks for (find_package)
and, through dpkg, which Debian package really provides each CMake config file,
message definition, Python message module and command that the build, the tests
and the README's commands use.
"""
import os
import pathlib
import re
import subprocess
import unittest
import xml.etree.ElementTree as ET

SOURCE = pathlib.Path(__file__).resolve().parents[2]
TABLE = SOURCE / "scripts" / "debian-dependencies.txt"
CMAKE_FILES = [SOURCE / "CMakeLists.txt", SOURCE / "test" / "fuzz" / "CMakeLists.txt",
               SOURCE / "cmake" / "relocalizer_dependencies.cmake"]
DEPEND_TAGS = ("depend", "build_depend", "build_export_depend", "exec_depend",
               "test_depend", "buildtool_depend", "doc_depend")

# Commands that the node's launch files, the tests and the README's lines run,
# with the table key whose run packages must provide them.
COMMANDS = {
    "/usr/bin/rosrun": "rosbash",
    "/usr/bin/rospack": "rosbash",
    "/usr/bin/roslaunch": "roslaunch",
    "/usr/bin/roscore": "roslaunch",      # make bench, scripts/soak.sh
    "/usr/bin/rosparam": "roslaunch",     # make bench, scripts/soak.sh
    "/usr/bin/rosmaster": "roslaunch",
    "/usr/lib/rosout/rosout": "roslaunch",
    "/usr/bin/rosservice": "rosservice",
    "/usr/bin/rostopic": "rostopic",
    "/usr/bin/rosbag": "rosbag",
    "/usr/bin/rostest": "rostest",
    "/usr/lib/nodelet/nodelet": "nodelet",
    "/usr/lib/python3/dist-packages/pytest/__init__.py": "python3-pytest",
    "/usr/bin/time": "make:bench",
    "/usr/bin/clang-format": "make:test",  # test/packaging/test_format.py
    "/usr/bin/rviz": "rviz",               # launch/view.launch
    "/usr/bin/Xvfb": "make:test",          # scripts/render_rviz.sh, run by the README test
    "/usr/bin/xwd": "make:test",
    "/usr/bin/rosdep": "make:test",        # ../shared/tools/rosdep-check, below
}
# Checks package.xml against the rosdep rules of every ROS 1 platform, offline.
ROSDEP_CHECK = SOURCE.parent / "shared" / "tools" / "rosdep-check"


SUITES = ("bullseye", "bookworm", "trixie")


def this_suite():
    """The Debian release here, as install_deps.sh reads it."""
    if os.environ.get("RELOCALIZER_SUITE"):
        return os.environ["RELOCALIZER_SUITE"]
    for line in pathlib.Path("/etc/os-release").read_text().splitlines():
        if line.startswith("VERSION_CODENAME="):
            return line.partition("=")[2].strip().strip('"')
    return ""


def packages_here(cell):
    """The packages of a table cell on this suite: name@suite items only on theirs."""
    if cell == "-":
        return []
    names = []
    for item in cell.split(","):
        name, _, suite = item.partition("@")
        if not suite or suite == this_suite():
            names.append(name)
    return names


class Row:
    def __init__(self, line_number, key, cmake, build, run):
        self.line_number = line_number
        self.key = key
        self.cmake = None if cmake == "-" else cmake
        self.cells = (build, run)
        self.build = packages_here(build)
        self.run = packages_here(run)


def read_table():
    rows = []
    for number, line in enumerate(TABLE.read_text().splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        fields = stripped.split()
        if len(fields) != 4:
            raise AssertionError(f"{TABLE}:{number}: expected 4 columns (key cmake build run), "
                                 f"got {len(fields)}: {line!r}")
        rows.append(Row(number, *fields))
    return rows


def package_xml_dependencies():
    root = ET.parse(SOURCE / "package.xml").getroot()
    return {element.text.strip() for tag in DEPEND_TAGS for element in root.iter(tag)}


def find_package_names():
    """Every name passed to find_package(), and every catkin COMPONENT."""
    names = set()
    for path in CMAKE_FILES:
        text = re.sub(r"#[^\n]*", "", path.read_text())
        for call in re.finditer(r"find_package\s*\(([^)]*)\)", text):
            words = call.group(1).split()
            names.add(words[0])
            if words[0] == "catkin" and "COMPONENTS" in words:
                names.update(words[words.index("COMPONENTS") + 1:])
    return names


def owning_packages(*path_fragments):
    """(path, Debian package) for every installed file whose path contains one of the
    fragments. One dpkg-query for all of them: each call reads every package's file list."""
    result = subprocess.run(["dpkg-query", "-S", *path_fragments], capture_output=True, text=True)
    pairs = []
    for line in result.stdout.splitlines():
        packages, _, path = line.partition(": ")
        for package in packages.split(", "):
            pairs.append((path.strip(), package.split(":")[0]))
    return pairs


_PACKAGE_DEPENDENCIES = {}


def package_dependencies():
    """Every package dpkg knows, by name, with its Depends and Pre-Depends, read once: a
    dpkg-query a package made this test take minutes on a loaded machine."""
    if not _PACKAGE_DEPENDENCIES:
        listed = subprocess.run(["dpkg-query", "-W", "-f=${Package}\t${Depends},${Pre-Depends}\n"],
                                capture_output=True, text=True, check=True)
        for line in listed.stdout.splitlines():
            name, _, dependencies = line.partition("\t")
            # A package installed for two architectures is listed twice.
            _PACKAGE_DEPENDENCIES[name] = ",".join(
                filter(None, (_PACKAGE_DEPENDENCIES.get(name, ""), dependencies)))
    return _PACKAGE_DEPENDENCIES


def installed_with(packages):
    """The packages and every installed package they depend on, transitively: what
    installing them installs. Debian's default-version packages such as
    libboost-program-options-dev own no files; their versioned dependencies do."""
    depends = package_dependencies()
    seen, pending = set(), list(packages)
    while pending:
        package = pending.pop()
        if package in seen:
            continue
        seen.add(package)
        for alternatives in depends.get(package, "").split(","):
            for alternative in alternatives.split("|"):
                name = alternative.split("(")[0].strip().split(":")[0]
                if name:
                    pending.append(name)
    return seen


def cmake_module_exists(name):
    """True when CMake itself ships Find<name>.cmake (found without a config file)."""
    return any(pathlib.Path("/usr/share").glob(f"cmake-*/Modules/Find{name}.cmake"))


class DependencyTableTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.rows = read_table()
        cls.by_key = {row.key: row for row in cls.rows}

    def test_suite_items_name_a_supported_suite(self):
        bad = [f"line {row.line_number}: {item}" for row in self.rows for cell in row.cells
               for item in cell.split(",") if "@" in item and item.partition("@")[2] not in SUITES]
        self.assertEqual(bad, [], f"{TABLE}: name@suite items must name one of {SUITES}")

    def test_keys_are_unique(self):
        keys = [row.key for row in self.rows]
        self.assertEqual(sorted(k for k in set(keys) if keys.count(k) > 1), [],
                         f"{TABLE}: a key appears on more than one row")

    def test_every_package_xml_dependency_has_a_row(self):
        missing = sorted(package_xml_dependencies() - set(self.by_key))
        self.assertEqual(missing, [], f"package.xml declares these, but {TABLE} does not say "
                         "which Debian packages provide them: add a row for each")

    def test_every_row_is_declared_in_package_xml(self):
        undeclared = sorted(k for k in self.by_key
                            if not k.startswith("make:") and k not in package_xml_dependencies())
        self.assertEqual(undeclared, [], f"{TABLE} has rows for keys that package.xml does not "
                         "declare: declare them in package.xml, or name the make target (make:...)")

    def test_every_find_package_has_a_row(self):
        table_names = {row.cmake for row in self.rows if row.cmake}
        missing = sorted(find_package_names() - table_names)
        self.assertEqual(missing, [], f"CMake looks for these, but no row of {TABLE} names them "
                         "in its cmake column")

    def test_every_cmake_name_in_the_table_is_looked_for(self):
        looked_for = find_package_names()
        stale = sorted(row.cmake for row in self.rows if row.cmake and row.cmake not in looked_for)
        self.assertEqual(stale, [], f"{TABLE} names CMake packages that no find_package() uses")

    def test_cmake_config_files_come_from_listed_build_packages(self):
        problems = []
        for row in self.rows:
            if not row.cmake:
                continue
            candidates = {f"{row.cmake}Config.cmake", f"{row.cmake}-config.cmake",
                          f"{row.cmake.lower()}Config.cmake", f"{row.cmake.lower()}-config.cmake"}
            owners = {package for path, package in owning_packages(
                *("*/" + candidate for candidate in sorted(candidates)))
                      if os.path.basename(path) in candidates}
            if not owners:
                if cmake_module_exists(row.cmake):
                    continue  # found by CMake's own Find module, e.g. ZLIB
                problems.append(f"{row.key}: no installed Debian package provides "
                                f"{row.cmake}Config.cmake (line {row.line_number}: is its "
                                "package missing from the build column?)")
            elif not owners & installed_with(row.build):
                problems.append(f"{row.key}: {row.cmake}'s CMake config comes from "
                                f"{', '.join(sorted(owners))}, which line {row.line_number} "
                                "does not list under build (nor does a package listed there "
                                "depend on it)")
        self.assertEqual(problems, [])

    def test_message_packages_bring_definitions_and_python_modules(self):
        # genmsg needs the .msg files to build our messages; rosservice and rostopic
        # need the Python modules of every message the service and topics carry.
        problems = []
        for row in self.rows:
            if not row.key.endswith("_msgs"):
                continue
            # A message package's dev package installs <key>-msg-paths.cmake; a
            # conversion library named *_msgs (tf2_geometry_msgs) installs only a config.
            if not owning_packages(f"*/{row.key}-msg-paths.cmake"):
                if not owning_packages(f"*/{row.key}Config.cmake"):
                    problems.append(f"{row.key}: not installed (neither {row.key}-msg-paths.cmake "
                                    f"nor {row.key}Config.cmake; line {row.line_number})")
                continue
            for fragment, column, name in ((f"/usr/share/{row.key}/msg", row.build, "build"),
                                           (f"/usr/lib/python3/dist-packages/{row.key}",
                                            row.run, "run")):
                owners = {package for path, package in owning_packages(fragment) if path == fragment}
                if not owners:
                    problems.append(f"{row.key}: no installed Debian package provides {fragment} "
                                    f"(line {row.line_number}: add it to the {name} column)")
                elif not owners & set(column):
                    problems.append(f"{row.key}: {fragment} comes from {', '.join(sorted(owners))}, "
                                    f"which line {row.line_number} does not list under {name}")
        self.assertEqual(problems, [])

    def test_commands_come_from_listed_run_packages(self):
        problems = []
        for command, key in sorted(COMMANDS.items()):
            row = self.by_key.get(key)
            if row is None:
                problems.append(f"{command}: the table has no row {key}")
                continue
            owners = {package for path, package in owning_packages(command) if path == command}
            if not owners:
                problems.append(f"{command}: not installed (add its Debian package to the run "
                                f"column of {key}, line {row.line_number})")
            elif not owners & set(row.run):
                problems.append(f"{command} comes from {', '.join(sorted(owners))}, which the run "
                                f"column of {key} (line {row.line_number}) does not list")
        self.assertEqual(problems, [])

    def test_install_script_installs_exactly_the_table(self):
        listed = subprocess.run([str(SOURCE / "scripts" / "install_deps.sh"), "--list"],
                                capture_output=True, text=True, check=True).stdout.split()
        expected = sorted({p for row in self.rows for p in row.build + row.run})
        self.assertEqual(listed, expected)


class RosdepTest(unittest.TestCase):
    def test_every_key_resolves_where_ros1_users_are(self):
        # `rosdep install --from-paths src --ignore-src` is how a catkin user installs
        # our dependencies: every key must resolve on Ubuntu 20.04-24.04 and Debian 11-13.
        if not ROSDEP_CHECK.is_file():
            self.skipTest(f"{ROSDEP_CHECK} is absent: the rosdep rules snapshot comes with ../shared")
        done = subprocess.run([str(ROSDEP_CHECK), str(SOURCE / "package.xml")],
                              capture_output=True, text=True, timeout=600)
        self.assertEqual(done.returncode, 0, f"{ROSDEP_CHECK} package.xml:\n{done.stdout}{done.stderr}")


if __name__ == "__main__":
    unittest.main()
