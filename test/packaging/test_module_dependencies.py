"""The modules depend on each other one way, as docs/architecture.md draws them.

docs/architecture.md has one table of the modules: their folders, their
libraries and the modules each may use. A header included from the wrong side
compiles without a word and quietly turns the picture into fiction, so these
tests read that table and fail when a source file includes a header of a module
it may not use, when a ROS-free module includes a ROS header, when CMake links a
module to one it may not use, or when the node would carry code it does not
need (the synthetic room, dataset readers, evaluation).
"""
import pathlib
import re
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
DOC = SOURCE / "docs" / "architecture.md"
CMAKE = SOURCE / "CMakeLists.txt"
TABLE_HEADER = ["module", "concern", "folders", "libraries", "may use"]
# The only modules that speak ROS; every other module builds without ROS.
ROS_MODULES = {"ros", "tools"}
# What the node executable and the nodelet may carry: the method, online learning and the ROS layer.
NODE_TARGETS = ("relocalizer_node", "relocalizer_nodelet")
NODE_MODULES = {"core", "surface", "forest", "pose", "relocalize", "online", "ros"}
SOURCE_SUFFIXES = (".h", ".hpp", ".cpp")


class Module:
    def __init__(self, name, folders, libraries, may_use):
        self.name = name
        self.folders = folders
        self.libraries = libraries
        self.may_use = may_use  # None: any module


def cells(line):
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def backticked(text):
    return re.findall(r"`([^`]+)`", text)


def read_modules():
    lines = DOC.read_text().splitlines()
    start = next((i for i, line in enumerate(lines)
                  if line.startswith("|") and cells(line) == TABLE_HEADER), None)
    if start is None:
        raise AssertionError(f"{DOC}: no module table with the columns {' | '.join(TABLE_HEADER)}")
    modules = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        name, _, folders, libraries, may_use = cells(line)
        name = name.strip("`")
        used = None if may_use.lower() == "any" else set(backticked(may_use))
        modules[name] = Module(name, [f.rstrip("/") for f in backticked(folders)],
                               backticked(libraries), used)
    for module in modules.values():
        unknown = (module.may_use or set()) - set(modules)
        if unknown:
            raise AssertionError(f"{DOC}: module {module.name} may use unknown modules {unknown}")
    return modules


def module_of_path(modules, path):
    """The module whose folder holds `path` (relative to SOURCE), or None."""
    text = path.as_posix()
    best = None
    for module in modules.values():
        for folder in module.folders:
            if text == folder or text.startswith(folder + "/"):
                if best is None or len(folder) > len(best[1]):
                    best = (module, folder)
    return best[0] if best else None


def ros_include_roots():
    """Include roots of the ROS packages the build finds through catkin (ros/, sensor_msgs/, ...).

    Read from find_package(catkin ... COMPONENTS ...), not from package.xml, whose
    system keys (tbb, boost) are no ROS packages."""
    text = re.sub(r"#[^\n]*", "", CMAKE.read_text())
    call = re.search(r"find_package\s*\(\s*catkin\s+REQUIRED\s+COMPONENTS([^)]*)\)", text)
    names = set(call.group(1).split()) if call else set()
    # Generated message headers of this package (<relocalizer/Relocalize.h>) are ROS too.
    return names | {"ros", "relocalizer"}


def includes(path):
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        match = re.match(r'\s*#\s*include\s*([<"])([^>"]+)[>"]', line)
        if match:
            yield number, match.group(1), match.group(2)


def cmake_links():
    """target -> relocalizer libraries it links, from target_link_libraries() and
    relocalizer_module()/relocalizer_tool() calls."""
    text = re.sub(r"#[^\n]*", "", CMAKE.read_text())
    links = {}
    for call, body in re.findall(r"\b(target_link_libraries|relocalizer_module|relocalizer_tool)"
                                 r"\s*\(([^)]*)\)", text):
        words = body.split()
        if not words or words[0].startswith("$"):
            continue  # the definitions inside the helper functions
        target = words[0] if call == "target_link_libraries" else (
            "relocalizer_" + words[0] if call == "relocalizer_module" else words[0])
        deps = {w for w in words[1:] if re.fullmatch(r"relocalizer_\w+", w)}
        links.setdefault(target, set()).update(deps)
    return links


def cmake_libraries():
    text = re.sub(r"#[^\n]*", "", CMAKE.read_text())
    libraries = set(re.findall(r"\badd_library\s*\(\s*(relocalizer_\w+)", text))
    libraries |= {"relocalizer_" + m for m in re.findall(r"\brelocalizer_module\s*\(\s*(\w+)", text)}
    return libraries


class ModuleDependencyTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.modules = read_modules()
        cls.library_module = {library: module for module in cls.modules.values()
                              for library in module.libraries}

    def source_files(self):
        for folder in ("src", "include"):
            for path in sorted((SOURCE / folder).rglob("*")):
                if path.suffix in SOURCE_SUFFIXES:
                    yield path.relative_to(SOURCE)

    def allowed(self, module, other):
        return other is module or module.may_use is None or other.name in module.may_use

    def test_every_source_file_belongs_to_a_module(self):
        orphans = [str(p) for p in self.source_files() if module_of_path(self.modules, p) is None]
        self.assertEqual(orphans, [], f"these files are in no folder of the module table in {DOC}: "
                         "add the folder to a module there")

    def test_includes_point_one_way(self):
        problems = []
        for path in self.source_files():
            module = module_of_path(self.modules, path)
            for number, _, header in includes(SOURCE / path):
                target = None
                project = re.match(r"relocalizer/(\w+)/", header)
                if project:
                    target = module_of_path(self.modules, pathlib.Path("include/relocalizer", project.group(1)))
                elif header.startswith("."):
                    resolved = (SOURCE / path).parent.joinpath(header).resolve()
                    if SOURCE in resolved.parents:
                        target = module_of_path(self.modules, resolved.relative_to(SOURCE))
                if target is not None and not self.allowed(module, target):
                    problems.append(f"{path}:{number}: {module.name} includes {header} of module "
                                    f"{target.name}, which it may not use")
        self.assertEqual(problems, [], f"dependencies against the table in {DOC}")

    def test_only_the_ros_layer_includes_ros_headers(self):
        roots = ros_include_roots()
        problems = []
        for path in self.source_files():
            module = module_of_path(self.modules, path)
            if module.name in ROS_MODULES:
                continue
            for number, bracket, header in includes(SOURCE / path):
                root = header.split("/")[0]
                if bracket == "<" and "/" in header and root in roots:
                    problems.append(f"{path}:{number}: the ROS-free module {module.name} includes "
                                    f"<{header}>")
        self.assertEqual(problems, [])

    def test_every_library_is_in_the_table(self):
        self.assertEqual(sorted(cmake_libraries() - set(self.library_module)), [],
                         f"CMake builds libraries that the module table in {DOC} does not name")
        self.assertEqual(sorted(set(self.library_module) - cmake_libraries()), [],
                         f"the module table in {DOC} names libraries that CMake does not build")

    def test_links_point_one_way(self):
        problems = []
        for target, deps in sorted(cmake_links().items()):
            module = self.library_module.get(target)
            if module is None:
                continue  # executables and tests may link any module they use
            for dep in sorted(deps):
                other = self.library_module.get(dep)
                if other is None:
                    problems.append(f"{target} links {dep}, which the module table does not name")
                elif not self.allowed(module, other):
                    problems.append(f"{target} ({module.name}) links {dep} of module {other.name}, "
                                    "which it may not use")
        self.assertEqual(problems, [], f"CMakeLists.txt against the table in {DOC}")

    def test_the_node_links_only_the_method_and_the_ros_layer(self):
        links = cmake_links()
        problems = []
        for node in NODE_TARGETS:
            seen, todo = set(), [node]
            while todo:
                for dep in links.get(todo.pop(), ()):
                    if dep not in seen:
                        seen.add(dep)
                        todo.append(dep)
            for library in sorted(seen):
                module = self.library_module.get(library)
                if module is not None and module.name not in NODE_MODULES:
                    problems.append(f"{node} links {library} (module {module.name})")
        self.assertEqual(problems, [], "the node carries what a camera relocalization does not need")

    def test_the_bag_reader_links_no_learner(self):
        # The tools' --bag reads frames; it selects key frames by a pose-only
        # rule (core/key_frame_rule.h), not by linking the learner.
        links = cmake_links()
        seen, todo = set(), ["relocalizer_bag"]
        while todo:
            for dep in links.get(todo.pop(), ()):
                if dep not in seen:
                    seen.add(dep)
                    todo.append(dep)
        self.assertIn("relocalizer_data", seen, "relocalizer_bag's links are not found")
        self.assertNotIn("relocalizer_online", seen, "relocalizer_bag links the learner")

    def test_the_fuzz_build_compiles_every_module_its_modules_use(self):
        # The fuzz build compiles the modules of the fuzzed parsers from source,
        # listed by hand in test/fuzz/CMakeLists.txt; a module those come to use
        # (the surface, for the model reader) only shows up as a link error in
        # `make fuzz`, which the package build and make test never run.
        text = (SOURCE / "test" / "fuzz" / "CMakeLists.txt").read_text()
        match = re.search(r"foreach\(module ([a-z ]+)\)", text)
        self.assertIsNotNone(match, "test/fuzz/CMakeLists.txt: no foreach(module ...) list of modules")
        listed = set(match.group(1).split())
        needed, todo = set(), list(listed)
        while todo:
            module = self.modules.get(todo.pop())
            self.assertIsNotNone(module, f"test/fuzz/CMakeLists.txt lists a module that {DOC.name} does not")
            for used in module.may_use or ():
                if used not in needed:
                    needed.add(used)
                    todo.append(used)
        self.assertEqual(sorted(needed - listed), [],
                         "test/fuzz/CMakeLists.txt compiles modules whose dependencies it leaves out")


if __name__ == "__main__":
    unittest.main()
