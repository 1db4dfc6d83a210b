"""The README's catkin workspace section, typed as a user types it (make test-workspaces).

A new workspace in a scratch folder (~/catkin_ws, HOME being the scratch folder's
home/) holds in src/ a copy of this checkout (its tracked and new files: no build/
nor devel/) and a second package, relocalizer_client, that calls the node's
~relocalize service through relocalizer's generated service header and parses its
argument with relocalizer_core's parseDecimal: it builds only if the messages, the
include folder and the libraries are exported. The section's lines run in order, each
in a fresh bash that has sourced only what the lines sourced before it:

- the catkin_make block: `catkin_make`, `catkin_make install`, `source install/setup.bash`,
  then its tools (`rosrun relocalizer ...`) and its `roslaunch` line, which must bring the
  node up from the install space (nothing of devel/ on the paths), answer the section's
  `rosservice call` line honestly (no camera: `success: False`, and why) and list the
  trained place; relocalizer_client gets the same answer; then the nodelet line must
  load the plugin from the install space and answer the same call;
- the catkin-tools block (Debian 12 and 13; Debian 11 has no catkin-tools package, so
  there these tests are skipped) in the same workspace once catkin_make's build/, devel/
  and install/ are gone, then the same runs.

ccache (CCACHE_DIR in the scratch folder) makes the second build mostly cache hits:
the same source paths and, with --merge-devel, the same devel/include. Every step's
wall time and ccache's hit rate are printed (pytest -s). RELOCALIZER_WS_KEEP=1 keeps
the scratch folder; RELOCALIZER_WS_SCRATCH=DIR works in DIR, kept, emptied first but
for its ccache/, so a second run there compiles nothing new.
"""
import os
import pathlib
import re
import shutil
import subprocess
import tempfile
import time
import unittest

import yaml

from test_readme_commands import SOURCE, WORKSPACE_SECTION, UserShell, readme_blocks

CLIENT_PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>relocalizer_client</name>
  <version>0.0.1</version>
  <description>Calls relocalizer's service: a package beside relocalizer in a workspace.</description>
  <maintainer email="nobody@example.com">nobody</maintainer>
  <license>BSD-3-Clause</license>
  <buildtool_depend>catkin</buildtool_depend>
  <depend>roscpp</depend>
  <depend>relocalizer</depend>
</package>
"""
CLIENT_CMAKE = """cmake_minimum_required(VERSION 3.16)
project(relocalizer_client)
set(CMAKE_CXX_STANDARD 17)
find_package(catkin REQUIRED COMPONENTS roscpp relocalizer)
catkin_package()
include_directories(${catkin_INCLUDE_DIRS})
add_executable(relocalize_once src/relocalize_once.cpp)
target_link_libraries(relocalize_once ${catkin_LIBRARIES})
add_dependencies(relocalize_once ${catkin_EXPORTED_TARGETS})
install(TARGETS relocalize_once RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
"""
CLIENT_SOURCE = r"""#include <cstdio>
#include <relocalizer/Relocalize.h>
#include <relocalizer/core/decimal_number.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "relocalize_once");
  const auto timeout = relocalizer::parseDecimal(argc > 1 ? argv[1] : "1.0");
  if (!timeout) {
    std::fprintf(stderr, "relocalize_once: '%s' is not a number of seconds\n", argv[1]);
    return 2;
  }
  relocalizer::Relocalize call;
  call.request.timeout = *timeout;
  if (!ros::service::waitForService("/relocalizer/relocalize", ros::Duration(30)) ||
      !ros::service::call("/relocalizer/relocalize", call)) {
    std::fprintf(stderr, "relocalize_once: /relocalizer/relocalize did not answer\n");
    return 1;
  }
  std::printf("success: %s\nmessage: %s\n", call.response.success ? "true" : "false",
              call.response.message.c_str());
  return 0;
}
"""
# What a build has no use for: the checkout's own build and devel folders.
NOT_COPIED = {".git", "build", "devel", "demo_output", "soak_output"}
BUILD_TIMEOUT = 5400


def section_blocks():
    blocks = [lines for section, lines in readme_blocks() if section == WORKSPACE_SECTION]
    if not blocks:
        raise AssertionError(f"README.md has no shell block under '## {WORKSPACE_SECTION}'")
    return blocks


def block_with(command):
    found = [lines for lines in section_blocks() if any(l.startswith(command) for l in lines)]
    if len(found) != 1:
        raise AssertionError(f"README.md's '{WORKSPACE_SECTION}' should have one block with "
                             f"`{command}`, has {len(found)}")
    return found[0]


def is_run_line(line):
    return line.startswith(("rosrun ", "roslaunch ", "rosservice "))


def checkout_files():
    """The files a clone of this checkout holds: git's tracked and new files, or, in a
    copy without .git, every file outside the build folders."""
    if (SOURCE / ".git").exists() and shutil.which("git"):
        listed = subprocess.run(["git", "-C", str(SOURCE), "ls-files", "-z", "--cached",
                                 "--others", "--exclude-standard"],
                                capture_output=True, text=True, check=True).stdout
        return [p for p in listed.split("\0") if p and (SOURCE / p).is_file()]
    return [str(p.relative_to(SOURCE)) for p in SOURCE.rglob("*")
            if p.is_file() and not (set(p.relative_to(SOURCE).parts) & NOT_COPIED)
            and not p.relative_to(SOURCE).parts[0].startswith("build-")
            and "__pycache__" not in p.parts]


def this_suite():
    for line in pathlib.Path("/etc/os-release").read_text().splitlines():
        if line.startswith("VERSION_CODENAME="):
            return line.partition("=")[2].strip().strip('"')
    return ""


class WorkspaceShell(UserShell):
    """A user's terminal: the folder the `cd` lines went to, what the `source` lines sourced."""

    def __init__(self, work):
        super().__init__(work)
        self.home = pathlib.Path(self.env["HOME"])
        self.reset()

    def reset(self):
        """A new terminal: in the home folder, nothing sourced."""
        self.cwd = self.home
        self.sourced = []

    def _script(self, line):
        sources = "".join(f"source {setup} && " for setup in self.sourced)
        return f'{sources}cd "{self.cwd}" && {line}'


class Workspace:
    """~/catkin_ws with relocalizer and relocalizer_client in src/, and a user's shell."""

    def __init__(self):
        scratch = os.environ.get("RELOCALIZER_WS_SCRATCH")
        if scratch:
            self.work = pathlib.Path(scratch)
            self.work.mkdir(parents=True, exist_ok=True)
            for path in self.work.iterdir():
                if path.name != "ccache":
                    shutil.rmtree(path) if path.is_dir() else path.unlink()
        else:
            self.work = pathlib.Path(tempfile.mkdtemp(prefix="catkin_workspace_"))
        self.shell = WorkspaceShell(self.work)
        self.root = self.shell.home / "catkin_ws"
        src = self.root / "src"
        for name in checkout_files():
            target = src / "relocalizer" / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(SOURCE / name, target)
        client = src / "relocalizer_client"
        (client / "src").mkdir(parents=True)
        (client / "package.xml").write_text(CLIENT_PACKAGE_XML)
        (client / "CMakeLists.txt").write_text(CLIENT_CMAKE)
        (client / "src" / "relocalize_once.cpp").write_text(CLIENT_SOURCE)
        if shutil.which("ccache"):
            # No CCACHE_BASEDIR: both builds compile the same absolute paths.
            self.shell.env.update({
                "CCACHE_DIR": str(self.work / "ccache"),
                "CCACHE_NOHASHDIR": "1", "CCACHE_MAXSIZE": "5G",
                "CMAKE_C_COMPILER_LAUNCHER": "ccache", "CMAKE_CXX_COMPILER_LAUNCHER": "ccache"})

    def run(self, line, timeout=120, log=None):
        """Runs a line as typed after the lines before it; `cd` and `source` carry on."""
        started = time.monotonic()
        probe = ' && echo "@@cwd $PWD"' if line.startswith("cd ") else ""
        result = self.shell.run(line + probe, timeout=timeout)
        print(f"[{time.monotonic() - started:7.1f} s] {line}", flush=True)
        if log:
            (self.work / log).write_text(result.stdout + result.stderr)
        if result.returncode == 0:
            if line.startswith("cd "):
                self.shell.cwd = re.findall(r"^@@cwd (.*)$", result.stdout, re.M)[-1]
            elif line.startswith("source "):
                self.shell.sourced.append(str(pathlib.Path(self.shell.cwd) / line.split()[1]))
        return result

    def ccache_summary(self):
        if "CCACHE_DIR" not in self.shell.env:
            return "no ccache"
        stats = subprocess.run(["ccache", "-s"], env=self.shell.env, capture_output=True,
                               text=True).stdout
        # The first hit and miss lines: the totals (ccache 4.2 names its lines "cache hit ...").
        lines = [re.sub(r"\s+", " ", l.strip()) for l in stats.splitlines()
                 if re.search(r"(?i)hit|miss", l)]
        return " | ".join(dict.fromkeys(lines[:4]))

    def cleanup(self):
        self.shell.stop_all()
        if os.environ.get("RELOCALIZER_WS_KEEP") or os.environ.get("RELOCALIZER_WS_SCRATCH"):
            print(f"kept {self.work}")
        else:
            shutil.rmtree(self.work, ignore_errors=True)


WORKSPACE = None


def workspace():
    global WORKSPACE
    if WORKSPACE is None:
        WORKSPACE = Workspace()
    return WORKSPACE


def tearDownModule():
    if WORKSPACE is not None:
        WORKSPACE.cleanup()


class WorkspaceRuns:
    """The section's runs against the install space of the build its class made."""

    build_command = ""
    skip_reason = ""

    @classmethod
    def setUpClass(cls):
        if cls.skip_reason:
            raise unittest.SkipTest(cls.skip_reason)
        cls.ws = workspace()
        cls.ws.shell.reset()
        cls.block = block_with(cls.build_command)
        cls.prepare()
        if "CCACHE_DIR" in cls.ws.shell.env:
            subprocess.run(["ccache", "-z"], env=cls.ws.shell.env, capture_output=True)
        cls.build_failure = None
        for number, line in enumerate(l for l in cls.block if not is_run_line(l)):
            result = cls.ws.run(line, timeout=BUILD_TIMEOUT, log=f"{cls.__name__}-{number}.txt")
            if result.returncode != 0:
                cls.build_failure = (f"`{line}` failed ({result.returncode}):\n"
                                     f"{result.stdout[-4000:]}\n{result.stderr[-4000:]}")
                break
        print(f"ccache after {cls.build_command}: {cls.ws.ccache_summary()}", flush=True)

    @classmethod
    def prepare(cls):
        pass

    def setUp(self):
        if self.build_failure:
            self.fail(self.build_failure)

    def tearDown(self):
        self.ws.shell.stop_all()

    def run_ok(self, line, timeout=120):
        result = self.ws.run(line, timeout=timeout)
        self.assertEqual(result.returncode, 0, f"`{line}`:\n{result.stdout}{result.stderr}")
        return result

    def lines(self, prefix):
        found = [l for lines in section_blocks() for l in lines if l.startswith(prefix)]
        self.assertTrue(found, f"README.md's '{WORKSPACE_SECTION}' has no `{prefix}...` line")
        return found

    def test_1_builds_beside_another_package_and_runs_from_the_install_space_only(self):
        install = self.ws.root / "install"
        self.assertEqual(self.ws.shell.sourced, [str(install / "setup.bash")],
                         "the section's build block should end by sourcing only the install space")
        for package in ("relocalizer", "relocalizer_client"):
            found = self.run_ok(f"rospack find {package}").stdout.strip()
            self.assertEqual(found, str(install / "share" / package))
        paths = self.run_ok('echo "$CMAKE_PREFIX_PATH:$ROS_PACKAGE_PATH:$LD_LIBRARY_PATH"').stdout
        self.assertNotIn(str(self.ws.root / "devel"), paths)
        self.assertNotIn(str(self.ws.root / "src"), paths)
        # The library the plugin file names: as is for pluginlib 1.x, lib<name> for 5.
        plugin = re.search(r'<library path="([^"]+)"', (SOURCE / "nodelet_plugins.xml").read_text())
        libraries = [install / "lib" / f"{prefix}{plugin.group(1)}.so" for prefix in ("", "lib")]
        self.assertEqual(sum(library.is_file() for library in libraries), 1,
                         f"exactly one of {libraries} should be installed")
        for path in ("lib/relocalizer/relocalizer_node", "lib/relocalizer/train",
                     "share/relocalizer/nodelet_plugins.xml",
                     "share/relocalizer/launch/relocalizer.launch",
                     "include/relocalizer/Relocalize.h", "lib/relocalizer_client/relocalize_once"):
            self.assertTrue((install / path).is_file(), f"{install / path} is not installed")

    def test_2_tools_do_their_work_from_the_install_space(self):
        for name in ("scene", "room.model"):
            shutil.rmtree(self.ws.root / name, ignore_errors=True)
        for line in self.lines("rosrun relocalizer "):
            self.run_ok(line, timeout=600)
        frames = sorted((self.ws.root / "scene" / "train").glob("frame-*.color.png"))
        self.assertEqual(len(frames), 20, "synthesize: the README asks for 20 training frames")
        self.assertGreater((self.ws.root / "room.model").stat().st_size, 10000)
        info = self.run_ok("rosrun relocalizer dataset_info --dataset scene/test").stdout
        self.assertIn("frames:       4 of 4", info)

    def answer(self, call):
        result = self.run_ok(call, timeout=60)
        return yaml.safe_load(result.stdout)

    def assert_honest_no_frame(self, call, answer):
        self.assertIs(answer["success"], False, f"`{call}` without a camera: {answer}")
        self.assertRegex(answer["message"], r"(?i)frame", f"`{call}` should say why")

    def node_answers(self, start_line, log):
        self.assertTrue((self.ws.root / "room.model").is_file(), "test_2 trains room.model")
        self.ws.shell.start(start_line, log)
        self.ws.shell.wait_until("rosservice list", "/relocalizer/relocalize", timeout=60)
        for call in self.lines("rosservice call /relocalizer/relocalize"):
            self.assert_honest_no_frame(call, self.answer(call))
        places = self.answer("rosservice call /relocalizer/list_places")["places"]
        self.assertEqual([p["name"] for p in places], ["room"], f"{start_line}: {places}")
        self.assertGreater(places[0]["point_trees"], 0)

    def test_3_launch_file_brings_the_node_up_and_it_answers(self):
        for launch in self.lines("roslaunch relocalizer "):
            with self.subTest(launch=launch):
                self.node_answers(launch, "roslaunch.log")
                client = self.run_ok("rosrun relocalizer_client relocalize_once 1.0", timeout=60)
                self.assertIn("success: false", client.stdout)
                self.assertRegex(client.stdout, r"message: .*frame")
                self.ws.shell.stop_all()

    def test_4_nodelet_loads_from_the_install_space_and_answers(self):
        for line in self.lines("rosrun nodelet nodelet "):
            with self.subTest(line=line):
                # The README's "with a roscore running".
                self.ws.shell.start(f"roscore -p {self.ws.shell.port}", "roscore.log")
                self.ws.shell.wait_until("rosparam get /rosdistro", "", timeout=60)
                self.node_answers(line, "nodelet.log")
                self.ws.shell.stop_all()


class CatkinMakeTest(WorkspaceRuns, unittest.TestCase):
    build_command = "catkin_make"


class CatkinBuildTest(WorkspaceRuns, unittest.TestCase):
    build_command = "catkin build"
    skip_reason = ("Debian 11 has no catkin-tools package: `catkin build` cannot run here"
                   if this_suite() == "bullseye" else "")

    @classmethod
    def prepare(cls):
        # "instead of catkin_make": catkin-tools refuses a build folder of catkin_make's.
        for name in ("build", "devel", "install"):
            shutil.rmtree(cls.ws.root / name, ignore_errors=True)


if __name__ == "__main__":
    unittest.main()
