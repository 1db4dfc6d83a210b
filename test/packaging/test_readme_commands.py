"""The commands of the README and of docs/, typed as a user types them.

Each command runs in a fresh bash that has only sourced the devel space the README
names (`source devel/setup.bash`), from a scratch folder holding the files the
lines refer to (model.bin, place.model and kitchen.model are the rostest
fixture's model, lab.model the model of its second room; test.bag is written by
`rosrun relocalizer make_bag`). The lines are read from the shell blocks of
README.md itself and of every docs/*.md it sends readers to (docs/node.md has the
place, hint, diagnostics and RViz lines, docs/tools.md the recording's,
docs/reliability.md the threshold curves'), README.md first, each distinct line once
("README" below means all of them):

- every `roslaunch relocalizer relocalizer.launch ...` line is launched verbatim and
  answered with the README's own `rosservice call` line (on-demand mode) or
  `rostopic echo` line (continuous mode), while `rosbag play` plays the fixture
  frames; the pose must be within 5 cm / 5 degrees of a ground-truth pose;
- every `roslaunch relocalizer relocalizer.launch places:=...` line is launched verbatim
  while the fixture frames play: the README's `rosservice call /relocalizer/relocalize`
  line must be answered by the place whose model is kitchen.model (the frames' room),
  within 5 cm / 5 degrees; then its `list_places` line must list every place the launch
  line names, and its `unload_place` and `load_place` lines must succeed, in that order,
  after which the place is listed again;
- every `rostopic pub -1 /initialpose ...` line is published verbatim to the first on-demand
  `roslaunch relocalizer relocalizer.launch` line's node while the fixture frames play: the
  node must log that it took the hint, and the README's relocalize call must then answer
  within 5 cm / 5 degrees and spend the hint;
- every hand-off line (`forward_initialpose:=true` or `set_pose_service:=...`) is launched
  verbatim with a static TF to its `handoff_frame`: after the README's service call, the pose
  of that frame must reach /initialpose or a stand-in robot_localization SetPose service;
- every `roslaunch relocalizer replay.launch ...` line is run verbatim;
- every `roslaunch relocalizer view.launch ...` line is launched verbatim on an X display of
  the test's own (Xvfb): ~surface must come latched in the map frame and RViz must subscribe
  to it; every `rosrun relocalizer render_rviz.sh ...` line is run verbatim and its PNG must
  not be blank: the surface's colours in over 5 % of the pixels, the inliers' in some, and
  many distinct colours (scripts/xwd_to_png.py --stats);
- every `roslaunch relocalizer relocalizer.launch learn:=true ...` line is launched
  verbatim while the fixture's training frames play with their poses on /tf (the
  rostest fixture's learn.bag), then the test frames play without TF and the README's
  `rosservice call /relocalizer/relocalize` line must place them (retried while the
  model is too young to answer; its first answer must be right), and its `rosservice call /relocalizer/save_model` line must write
  the learned folder (manifest.json and each submap's key frames);
- the README's `rostopic echo -n 1 /diagnostics` line, run after its on-demand launch
  line and `rosservice call /relocalizer/relocalize` line answered, must show the node's
  status OK with the pose's age and the fixture model's place;
- every tool named by a `rosrun relocalizer <tool>` line answers `--help` through
  rosrun, and `rosrun relocalizer train --help` is run exactly as written.

A private ROS master (ROS_MASTER_URI on a free port) keeps the test away from any
master that runs on this machine.
"""
import json
import math
import os
import pathlib
import re
import signal
import subprocess
import tempfile
import time
import unittest

import yaml

SOURCE = pathlib.Path(__file__).resolve().parents[2]
README = SOURCE / "README.md"
# The README first: the checks that take one line of a kind take its first.
COMMAND_FILES = [README] + sorted((SOURCE / "docs").glob("*.md"))
DEVEL = pathlib.Path(os.environ.get("RELOCALIZER_DEVEL", SOURCE / "devel"))
FIXTURE = pathlib.Path(os.environ.get("RELOCALIZER_FIXTURE", SOURCE / "build" / "rostest_fixture"))
COMMAND_PREFIXES = ("rosrun relocalizer ", "roslaunch relocalizer ", "rosservice call /relocalizer",
                    "rostopic echo /relocalizer", "rostopic echo -n 1 /diagnostics",
                    "rostopic pub -1 /initialpose ")


# Its lines build a catkin workspace: test_catkin_workspace.py runs them (make test-workspaces).
WORKSPACE_SECTION = "In a catkin workspace"


def readme_commands():
    """The lines of the shell blocks of README.md and docs/*.md that call this package,
    continuations joined, each distinct line once, in the order they are read; but for
    the lines of README.md's catkin workspace section."""
    commands = []
    for path in COMMAND_FILES:
        for section, lines in shell_blocks(path):
            if path == README and section == WORKSPACE_SECTION:
                continue
            commands += [line for line in lines
                         if line.startswith(COMMAND_PREFIXES) and line not in commands]
    return commands


def readme_blocks():
    """(section title, lines) of every shell block of README.md."""
    return shell_blocks(README)


def shell_blocks(path):
    """(section title, lines) of every sh and bash block of one Markdown file,
    continuations joined and comments dropped; the section is the `## ` heading the
    block sits under."""
    blocks = []
    section = ""
    lines = None
    pending = ""
    for line in path.read_text().splitlines():
        # Fences indented under a list item count too: a step's command is a command.
        if line.lstrip().startswith("```"):
            if lines is not None:
                blocks.append((section, lines))
            lines = [] if line.strip() in ("```sh", "```bash") else None
            pending = ""
            continue
        if lines is None:
            if line.startswith("## "):
                section = line[3:].strip()
            continue
        line = pending + line.strip()
        if line.endswith("\\"):
            pending = line[:-1].rstrip() + " "
            continue
        pending = ""
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line:
            lines.append(line)
    return blocks


def free_port():
    """A port for the private master, chosen as every private master of the package's
    scripts chooses it (private_port in scripts/private_master.sh: outside the kernel's
    ephemeral range, where another process can take it before roscore binds it)."""
    chosen = subprocess.run(["bash", "-c", f'source "{SOURCE}/scripts/private_master.sh" '
                             "&& private_port"], capture_output=True, text=True, check=True)
    return int(chosen.stdout)


def ground_truth_poses():
    """(rotation rows, translation) of every fixture test frame (camera to world)."""
    poses = []
    for path in sorted((FIXTURE / "scene" / "test").glob("frame-*.pose.txt")):
        m = [[float(v) for v in row.split()] for row in path.read_text().split("\n") if row.strip()]
        poses.append(([row[:3] for row in m[:3]], [row[3] for row in m[:3]]))
    return poses


def quaternion_matrix(q):
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


class UserShell:
    """Runs command lines in bash as a user would after `source devel/setup.bash`."""

    def __init__(self, work):
        self.work = work
        self.port = free_port()
        self.background = []
        home = work / "home"
        home.mkdir()
        self.env = {"HOME": str(home), "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8",
                    "ROS_MASTER_URI": f"http://localhost:{self.port}",
                    "ROS_LOG_DIR": str(work / "ros_log")}

    def _script(self, line):
        return f'source "{DEVEL}/setup.bash" && cd "{self.work}" && {line}'

    def run(self, line, timeout=120):
        return subprocess.run(["bash", "-c", self._script(line)], env=self.env, cwd=self.work,
                              capture_output=True, text=True, timeout=timeout)

    def start(self, line, log_name):
        log = open(self.work / log_name, "w")
        process = subprocess.Popen(["bash", "-c", self._script("exec " + line)], env=self.env,
                                   cwd=self.work, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
        self.background.append((process, log))
        return process

    def stop_all(self):
        for process, _ in reversed(self.background):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGINT)
        for process, log in reversed(self.background):
            try:
                process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
            log.close()
        self.background = []

    def logs(self):
        """The last lines of every background command's output, for failure messages."""
        text = ""
        for path in sorted(self.work.glob("*.log")):
            lines = path.read_text(errors="replace").splitlines()[-25:]
            text += f"\n--- {path.name} (last {len(lines)} lines)\n" + "\n".join(lines)
        return text

    def wait_until(self, line, what, timeout=60):
        deadline = time.monotonic() + timeout
        result = None
        while time.monotonic() < deadline:
            result = self.run(line, timeout=30)
            if result.returncode == 0 and what in result.stdout:
                return
            time.sleep(0.5)
        raise AssertionError(f"gave up after {timeout} s waiting for '{what}' from `{line}` "
                             f"(last exit {result.returncode}: {result.stderr.strip()[-500:]})"
                             + self.logs())


class ReadmeCommandsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not (DEVEL / "setup.bash").is_file():
            raise AssertionError(f"{DEVEL}/setup.bash is missing: build first (make build)")
        if not (FIXTURE / "model.bin").is_file():
            raise AssertionError(f"{FIXTURE}/model.bin is missing: the rostest fixture is built "
                                 "with the tests (make test)")
        cls.commands = readme_commands()
        cls.scratch = tempfile.TemporaryDirectory(prefix="readme_commands_")
        cls.work = pathlib.Path(cls.scratch.name)
        if not (FIXTURE / "model2.bin").is_file():
            raise AssertionError(f"{FIXTURE}/model2.bin is missing: rebuild the rostest fixture")
        for name in ("model.bin", "place.model", "kitchen.model"):
            (cls.work / name).symlink_to(FIXTURE / "model.bin")
        (cls.work / "lab.model").symlink_to(FIXTURE / "model2.bin")
        shell = UserShell(cls.work)
        made = shell.run(f'rosrun relocalizer make_bag --dataset "{FIXTURE}/scene/test" '
                         "--output test.bag")
        if made.returncode != 0:
            raise AssertionError(f"rosrun relocalizer make_bag failed:\n{made.stdout}{made.stderr}")
        cls.truth = ground_truth_poses()

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def setUp(self):
        self.shell = UserShell(pathlib.Path(tempfile.mkdtemp(dir=self.work)))
        for name in ("model.bin", "place.model", "kitchen.model", "lab.model", "test.bag"):
            (self.shell.work / name).symlink_to(self.work / name)

    def tearDown(self):
        self.shell.stop_all()

    def readme_lines(self, prefix):
        lines = [c for c in self.commands if c.startswith(prefix)]
        self.assertTrue(lines, f"neither README.md nor docs/*.md has a `{prefix}...` line")
        return lines

    def assert_near_ground_truth(self, position, orientation, line):
        rotation = quaternion_matrix(orientation)
        best = None
        for truth_rotation, truth_translation in self.truth:
            translation_error = math.dist(truth_translation, position)
            # trace(truth^T rotation) = sum of the element-wise product
            trace = sum(a * b for ra, rb in zip(truth_rotation, rotation) for a, b in zip(ra, rb))
            cosine = (trace - 1) / 2
            angle = math.degrees(math.acos(max(-1.0, min(1.0, cosine))))
            if best is None or translation_error < best[0]:
                best = (translation_error, angle)
        self.assertLess(best[0], 0.05, f"`{line}`: pose is {best[0]:.3f} m from the nearest "
                        "ground-truth pose of the frames played")
        self.assertLess(best[1], 5.0, f"`{line}`: pose is {best[1]:.2f} deg off")

    def play_fixture_frames(self, odom_frame):
        # roslaunch brings up the master and the node, which advertises ~result at
        # start; rostopic and rosbag give up without a master.
        self.shell.wait_until("rostopic list", "/relocalizer/result")
        if odom_frame:
            # What a SLAM stack would publish: odom -> camera (here fixed, so static).
            self.shell.start(
                "rostopic pub -l /tf_static tf2_msgs/TFMessage \"transforms: [{header: "
                f"{{frame_id: {odom_frame}}}, child_frame_id: camera_rgb_optical_frame, "
                "transform: {rotation: {w: 1.0}}}]\"", "tf_static.log")
            self.shell.wait_until("rostopic echo -n 1 /tf_static", f"frame_id: \"{odom_frame}\"")
        self.shell.start("rosbag play --loop --quiet test.bag", "rosbag_play.log")
        self.shell.wait_until("rostopic echo -n 1 /camera/rgb/camera_info", "header")

    def test_rosrun_train_help_exactly_as_written(self):
        line = "rosrun relocalizer train --help"
        self.assertIn(line, self.commands, "README.md should show how to get the tools' help")
        result = self.shell.run(line)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        self.assertIn("--dataset", result.stdout)
        self.assertIn("--output", result.stdout)

    def test_every_readme_tool_answers_help_through_rosrun(self):
        tools = sorted({c.split()[2] for c in self.readme_lines("rosrun relocalizer ")})
        for tool in tools:
            with self.subTest(tool=tool):
                result = self.shell.run(f"rosrun relocalizer {tool} --help")
                self.assertEqual(result.returncode, 0,
                                 f"rosrun relocalizer {tool} --help:\n{result.stdout}{result.stderr}")
                self.assertRegex(result.stdout, r"(?i)usage|--help")

    def test_relocalizer_launch_lines_answer_the_readme_service_call(self):
        calls = self.readme_lines("rosservice call /relocalizer/relocalize")
        launches = [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                    if "mode:=continuous" not in c and "learn:=true" not in c
                    and "places:=" not in c]
        self.assertTrue(launches, "neither README.md nor docs/*.md has an on-demand "
                        "relocalizer.launch line")
        for launch in launches:
            with self.subTest(launch=launch):
                self.shell.start(launch, "roslaunch.log")
                odom = re.search(r"odom_frame:=(\S+)", launch)
                self.play_fixture_frames(odom.group(1) if odom else "")
                for call in sorted(set(calls)):
                    result = self.shell.run(call, timeout=60)
                    self.assertEqual(result.returncode, 0, f"`{call}`:\n{result.stdout}{result.stderr}")
                    answer = yaml.safe_load(result.stdout)
                    self.assertTrue(answer["success"], f"`{call}` after `{launch}`: {answer['message']}")
                    pose = answer["pose"]["pose"]["pose"]
                    p, q = pose["position"], pose["orientation"]
                    self.assert_near_ground_truth([p["x"], p["y"], p["z"]],
                                                  [q["x"], q["y"], q["z"], q["w"]], call)
                self.shell.stop_all()

    def call_yaml(self, call):
        result = self.shell.run(call, timeout=60)
        self.assertEqual(result.returncode, 0, f"`{call}`:\n{result.stdout}{result.stderr}")
        return yaml.safe_load(result.stdout)

    def test_places_launch_line_answers_and_the_place_services_work(self):
        call = self.readme_lines("rosservice call /relocalizer/relocalize")[0]
        listing = self.readme_lines("rosservice call /relocalizer/list_places")[0]
        unload = self.readme_lines("rosservice call /relocalizer/unload_place")[0]
        load = self.readme_lines("rosservice call /relocalizer/load_place")[0]
        for launch in [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                       if "places:=" in c]:
            with self.subTest(launch=launch):
                names = re.findall(r"name: (\w+)", launch)
                kitchen = re.search(r"name: (\w+), model: \$PWD/kitchen\.model", launch)
                self.assertTrue(kitchen, f"`{launch}` has no place with model $PWD/kitchen.model")
                self.shell.start(launch, "roslaunch.log")
                self.play_fixture_frames("")
                answer = self.call_yaml(call)
                self.assertTrue(answer["success"], f"`{call}` after `{launch}`: {answer['message']}"
                                + self.shell.logs())
                self.assertEqual(answer["place"], kitchen.group(1))
                pose = answer["pose"]["pose"]["pose"]
                p, q = pose["position"], pose["orientation"]
                self.assert_near_ground_truth([p["x"], p["y"], p["z"]],
                                              [q["x"], q["y"], q["z"], q["w"]], call)
                listed = [place["name"] for place in self.call_yaml(listing)["places"]]
                self.assertEqual(sorted(listed), sorted(names), listing)
                for line in (unload, load):
                    answer = self.call_yaml(line)
                    self.assertTrue(answer["success"], f"`{line}`: {answer['message']}")
                listed = [place["name"] for place in self.call_yaml(listing)["places"]]
                self.assertEqual(sorted(listed), sorted(names), f"{listing} after `{load}`")
                self.shell.stop_all()

    def test_initialpose_line_gives_a_hint_the_next_call_uses(self):
        call = self.readme_lines("rosservice call /relocalizer/relocalize")[0]
        launch = [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                  if "mode:=" not in c and "learn:=" not in c and "places:=" not in c][0]
        odom = re.search(r"odom_frame:=(\S+)", launch)
        for hint in self.readme_lines("rostopic pub -1 /initialpose "):
            with self.subTest(hint=hint):
                self.shell.start(launch, "roslaunch.log")
                self.play_fixture_frames(odom.group(1) if odom else "")
                # The node's INFO lines reach a redirected stdout late (buffered);
                # rostopic echo flushes each message.
                self.shell.start("rostopic echo /rosout", "rosout.log")
                self.shell.wait_until("rostopic info /rosout", "/rostopic_")
                published = self.shell.run(hint, timeout=60)
                self.assertEqual(published.returncode, 0, published.stdout + published.stderr)
                log = self.shell.work / "rosout.log"
                deadline = time.monotonic() + 30
                while "pose hint on /initialpose from" not in log.read_text(errors="replace"):
                    self.assertLess(time.monotonic(), deadline, "the node never took `" + hint + "`"
                                    + self.shell.logs())
                    time.sleep(0.2)
                answer = self.call_yaml(call)
                self.assertTrue(answer["success"], f"`{call}` after `{hint}`: {answer['message']}")
                pose = answer["pose"]["pose"]["pose"]
                p, q = pose["position"], pose["orientation"]
                self.assert_near_ground_truth([p["x"], p["y"], p["z"]],
                                              [q["x"], q["y"], q["z"], q["w"]], call)
                deadline = time.monotonic() + 30
                while "with the pose hint, which is now spent" not in log.read_text(errors="replace"):
                    self.assertLess(time.monotonic(), deadline, "the hint was not used"
                                    + self.shell.logs())
                    time.sleep(0.2)
                self.shell.stop_all()

    def test_continuous_launch_line_publishes_what_the_readme_echoes(self):
        echo = self.readme_lines("rostopic echo /relocalizer/pose")[0]
        for launch in [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                       if "mode:=continuous" in c]:
            with self.subTest(launch=launch):
                self.shell.start(launch, "roslaunch.log")
                self.play_fixture_frames("")
                # The README's echo runs until interrupted; its first message is enough.
                result = self.shell.run(echo.replace("rostopic echo ", "rostopic echo -n 1 ", 1),
                                        timeout=60)
                self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
                message = yaml.safe_load(result.stdout.split("---")[0])
                pose = message["pose"]["pose"]
                p, q = pose["position"], pose["orientation"]
                self.assert_near_ground_truth([p["x"], p["y"], p["z"]],
                                              [q["x"], q["y"], q["z"], q["w"]], echo)
                self.shell.stop_all()

    def test_learn_launch_line_learns_from_tf_relocalizes_and_saves(self):
        calls = self.readme_lines("rosservice call /relocalizer/relocalize")
        saves = self.readme_lines("rosservice call /relocalizer/save_model")
        for launch in [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                       if "learn:=true" in c]:
            with self.subTest(launch=launch):
                self.shell.start(launch, "roslaunch.log")
                self.shell.wait_until("rostopic list", "/relocalizer/result")
                # What SLAM publishes while it tracks: images and map -> odom -> camera.
                played = self.shell.run(f'rosbag play --quiet -d 1 "{FIXTURE}/learn.bag"', timeout=120)
                self.assertEqual(played.returncode, 0, played.stdout + played.stderr)
                # Tracking lost: frames without TF; the learned model must place them.
                self.shell.start("rosbag play --loop --quiet test.bag", "rosbag_play.log")
                for call in sorted(set(calls)):
                    deadline = time.monotonic() + 120
                    while True:
                        result = self.shell.run(call, timeout=60)
                        self.assertEqual(result.returncode, 0, f"`{call}`:\n{result.stdout}{result.stderr}")
                        answer = yaml.safe_load(result.stdout)
                        # A young model may still lack the evidence for these views
                        # ("no model yet", "weak evidence"); the first answer must be right.
                        if answer["success"] or time.monotonic() > deadline:
                            break
                        time.sleep(1.0)
                    self.assertTrue(answer["success"], f"`{call}` after `{launch}`: {answer['message']}"
                                    + self.shell.logs())
                    pose = answer["pose"]["pose"]["pose"]
                    p, q = pose["position"], pose["orientation"]
                    self.assert_near_ground_truth([p["x"], p["y"], p["z"]],
                                                  [q["x"], q["y"], q["z"], q["w"]], call)
                for save in saves:
                    result = self.shell.run(save, timeout=60)
                    self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
                    self.assertTrue(yaml.safe_load(result.stdout)["success"], result.stdout)
                    # Relative: inside save_model_folder, which the launch line sets to $PWD.
                    path = re.search(r"path: (\S+?)[}\"]", save).group(1)
                    manifest = json.loads((self.shell.work / path / "manifest.json").read_text())
                    self.assertGreaterEqual(len(manifest["submaps"]), 1, save)
                    for submap in manifest["submaps"]:
                        self.assertTrue((self.shell.work / path / submap["keyframes"]).is_file(), save)
                self.shell.stop_all()

    def test_diagnostics_line_shows_the_node_ok_after_an_answer(self):
        echo = self.readme_lines("rostopic echo -n 1 /diagnostics")[0]
        call = self.readme_lines("rosservice call /relocalizer/relocalize")[0]
        launch = [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                  if "mode:=continuous" not in c and "learn:=true" not in c
                  and "places:=" not in c][0]
        self.shell.start(launch, "roslaunch.log")
        odom = re.search(r"odom_frame:=(\S+)", launch)
        self.play_fixture_frames(odom.group(1) if odom else "")
        answer = self.call_yaml(call)
        self.assertTrue(answer["success"], f"`{call}` after `{launch}`: {answer['message']}")
        # Statuses come every second; the first one after the answer says so.
        deadline = time.monotonic() + 60
        while True:
            result = self.shell.run(echo, timeout=60)
            self.assertEqual(result.returncode, 0, f"`{echo}`:\n{result.stdout}{result.stderr}")
            array = yaml.safe_load(result.stdout.split("\n---")[0])
            node = [s for s in array["status"] if s["name"] == "relocalizer: relocalization"]
            self.assertEqual(len(node), 1, f"`{echo}`: {result.stdout}")
            values = {v["key"]: v["value"] for v in node[0]["values"]}
            if values["last pose age (s)"] != "none yet" or time.monotonic() > deadline:
                break
            time.sleep(0.5)
        self.assertEqual(node[0]["level"], 0, f"`{echo}`: {result.stdout}")
        self.assertEqual(node[0]["hardware_id"], "relocalizer: /relocalizer")
        self.assertTrue(node[0]["message"].startswith("last pose "), node[0]["message"])
        self.assertEqual(values["places"], "model (map)")
        self.assertGreaterEqual(int(values["frames processed"]), 1)
    def test_handoff_launch_lines_hand_the_answer_to_amcl_and_robot_localization(self):
        """The hand-off lines: the answer's pose reaches /initialpose (what amcl reads) or a
        robot_localization SetPose service (a stand-in serving that very type name), as the
        pose of handoff_frame, which a static TF puts 0.3 m below the camera."""
        call = self.readme_lines("rosservice call /relocalizer/relocalize")[0]
        launches = [c for c in self.readme_lines("roslaunch relocalizer relocalizer.launch")
                    if "forward_initialpose:=true" in c or "set_pose_service:=" in c]
        self.assertTrue(launches, "neither README.md nor docs/*.md has a hand-off line")
        for launch in launches:
            with self.subTest(launch=launch):
                self.shell.start(launch, "roslaunch.log")
                self.shell.wait_until("rostopic list", "/relocalizer/result")
                frame = re.search(r"handoff_frame:=(\S+)", launch)
                if frame:
                    self.shell.start(
                        "rostopic pub -l /tf_static tf2_msgs/TFMessage \"transforms: [{header: "
                        "{frame_id: camera_rgb_optical_frame}, child_frame_id: "
                        f"{frame.group(1)}, transform: {{translation: {{y: 0.3}}, "
                        "rotation: {w: 1.0}}}]\"", "tf_static.log")
                # A file of this line's own: the class shares one scratch folder, and a
                # file left by the line before held that line's pose, which the wait
                # below took for this one's (issue 38: 1.5-2 mm off under load).
                handed = self.shell.work / f"handed_{launches.index(launch)}.yaml"
                handed.unlink(missing_ok=True)
                service = re.search(r"set_pose_service:=(\S+)", launch)
                if service:
                    self.shell.start(f"python3 {SOURCE}/test/packaging/fake_set_pose.py "
                                     f"{service.group(1)} {handed}", "fake_set_pose.log")
                    self.shell.wait_until("rosservice list", service.group(1))
                else:
                    self.shell.start("rostopic echo -n 1 /initialpose", handed.name)
                    self.shell.wait_until("rostopic info /initialpose", "* /rostopic_")
                self.shell.start("rosbag play --loop --quiet test.bag", "rosbag_play.log")
                answer = self.call_yaml(call)
                self.assertTrue(answer["success"], f"`{call}` after `{launch}`: {answer['message']}")
                # The pose handed off for this answer: the one of the answer's stamp.
                stamp = answer["pose"]["header"]["stamp"]
                deadline = time.monotonic() + 30
                pose = None
                while pose is None and time.monotonic() < deadline:
                    try:  # the last pose may be half written
                        handed_poses = [yaml.safe_load(part) for part in
                                        (handed.read_text().split("---") if handed.exists() else [])
                                        if "orientation" in part]
                    except yaml.YAMLError:
                        handed_poses = []
                    pose = next((p for p in handed_poses if p["header"]["stamp"] == stamp), None)
                    time.sleep(0.2)
                self.assertIsNotNone(pose, f"no pose handed off at {stamp}" + self.shell.logs())
                self.assertEqual(pose["header"]["frame_id"], "map", self.shell.logs())
                camera = answer["pose"]["pose"]["pose"]["position"]
                base = pose["pose"]["pose"]["position"]
                lever = math.dist([camera["x"], camera["y"], camera["z"]],
                                  [base["x"], base["y"], base["z"]])
                self.assertAlmostEqual(lever, 0.3 if frame else 0.0, delta=1e-3, msg=launch)
                self.shell.stop_all()

    def test_replay_launch_line_prints_the_evaluation(self):
        for launch in self.readme_lines("roslaunch relocalizer replay.launch"):
            with self.subTest(launch=launch):
                result = self.shell.run(launch, timeout=300)
                self.assertEqual(result.returncode, 0, result.stdout[-3000:] + result.stderr[-3000:])
                self.assertIn("within 5 cm / 5", result.stdout)
                output = re.search(r"output:=\$PWD/(\S+)", launch)
                if output:
                    self.assertTrue((self.shell.work / output.group(1) / "summary.json").is_file())

    def test_view_launch_line_starts_rviz_on_the_latched_surface(self):
        for launch in self.readme_lines("roslaunch relocalizer view.launch"):
            with self.subTest(launch=launch):
                # RViz under Xvfb's software GL now and then dies of SIGSEGV as it
                # starts on a loaded machine (Debian 11's RViz 1.14 in CI on 2026-11-28),
                # in its own code: the launch is started once more then, and only then.
                for attempt in (1, 2):
                    if self.view_launch_subscribes_rviz(launch, last_attempt=attempt == 2):
                        break
                    print("RViz died of SIGSEGV as it started under Xvfb; the launch once more",
                          flush=True)

    def view_launch_subscribes_rviz(self, launch, last_attempt):
        """True once RViz subscribes to the latched surface; False when RViz
        crashed as it started (and this is not the last attempt)."""
        xvfb = subprocess.Popen(["Xvfb", "-displayfd", "1", "-screen", "0", "1000x640x24",
                                 "-nolisten", "tcp"], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)
        try:
            self.shell.env["DISPLAY"] = ":" + xvfb.stdout.readline().strip()
            self.shell.start(launch, "view.log")
            self.shell.wait_until("rostopic echo -n 1 /relocalizer/surface/header",
                                  'frame_id: "map"', timeout=120)
            try:
                self.shell.wait_until("rostopic info /relocalizer/surface", "* /rviz",
                                      timeout=120)
                return True
            except AssertionError:
                log = (self.shell.work / "view.log").read_text(errors="replace")
                if last_attempt or not re.search(r"\[rviz-\d+\] process has died \[pid \d+, "
                                                 r"exit code -11,", log):
                    raise
                return False
        finally:
            self.shell.stop_all()
            xvfb.terminate()
            xvfb.wait(timeout=15)

    def test_render_line_saves_a_picture_that_is_not_blank(self):
        for line in self.readme_lines("rosrun relocalizer render_rviz.sh"):
            with self.subTest(line=line):
                started = time.monotonic()
                result = self.shell.run(line, timeout=600)
                self.assertEqual(result.returncode, 0, result.stdout[-3000:] + result.stderr[-3000:])
                picture = self.shell.work / re.search(r"--output (\S+)", line).group(1)
                stats = json.loads(subprocess.run(
                    ["/usr/bin/python3", str(SOURCE / "scripts" / "xwd_to_png.py"), "--stats",
                     str(picture)], capture_output=True, text=True, check=True).stdout)
                share = stats["share"]
                print(f"`{line}`: {time.monotonic() - started:.0f} s, {stats}")
                self.assertGreater(share["surface"], 0.05, f"no surface drawn: {stats}")
                self.assertGreater(share["points"] + share["lines"], 0.001, f"no inliers: {stats}")
                self.assertGreater(stats["colours"], 100, f"too few colours: {stats}")


if __name__ == "__main__":
    unittest.main()
