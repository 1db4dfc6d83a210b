"""Facts that have one owner in the code stay with it (issue 41).

- TF: the node owns one tf2_ros::Buffer and one TransformListener and lends
  the buffer to its parts (src/ros/node/relocalizer_node.h). roscpp merges a
  process's subscriptions to one topic into one connection, so the master and
  `rosnode info` show the node once on /tf however many listeners it has; each
  listener still keeps its own cache and thread, and only the source tells.
- A model file is framed in one place (modelFileReplacement, model_io.cpp):
  every other writer goes through it rather than pairing kModelMagic with
  serialized bytes by hand.
"""
import pathlib
import re
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
SOURCE_SUFFIXES = (".h", ".hpp", ".cpp")


def code_files(*folders):
    for folder in folders:
        for path in sorted((SOURCE / folder).rglob("*")):
            if path.suffix in SOURCE_SUFFIXES:
                yield path


def code_of(path):
    """The file without its comments, so that prose naming a type is no use of it."""
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def files_matching(pattern, *folders):
    found = set()
    for path in code_files(*folders):
        if re.search(pattern, code_of(path)):
            found.add(str(path.relative_to(SOURCE)))
    return found


# A tf2_ros::Buffer object: a member or variable of the type itself, or one
# made on the heap (a reference or pointer to one is a loan, not a buffer).
BUFFER_MADE = r"tf2_ros::Buffer\s+\w+\s*[;({]|(make_unique|make_shared|new)\s*<?\s*tf2_ros::Buffer\b"
LISTENER_MADE = r"tf2_ros::TransformListener\s+\w+\s*[;({]|(make_unique|make_shared|new)\s*<?\s*tf2_ros::TransformListener\b"
NODE_FILES = {"src/ros/node/relocalizer_node.h", "src/ros/node/relocalizer_node.cpp"}


class OneTfBuffer(unittest.TestCase):
    def test_only_the_node_makes_a_tf_buffer(self):
        made = files_matching(BUFFER_MADE, "src", "include")
        self.assertTrue(made, "no tf2_ros::Buffer found at all: the pattern is out of date")
        self.assertLessEqual(made, NODE_FILES, "tf2_ros::Buffer made outside the node")

    def test_only_the_node_makes_a_tf_listener(self):
        made = files_matching(LISTENER_MADE, "src", "include")
        self.assertTrue(made, "no tf2_ros::TransformListener found at all: the pattern is out of date")
        self.assertLessEqual(made, NODE_FILES, "tf2_ros::TransformListener made outside the node")

    def test_the_node_makes_one_of_each(self):
        code = "".join(code_of(SOURCE / f) for f in sorted(NODE_FILES))
        self.assertEqual(len(re.findall(BUFFER_MADE, code)), 1)
        self.assertEqual(len(re.findall(LISTENER_MADE, code)), 1)


class OneModelFileFraming(unittest.TestCase):
    def test_only_model_io_pairs_the_magic_with_the_bytes(self):
        # kModelMagic is also what a reader checks (place_files.cpp); a writer
        # names it inside a FileReplacement's braces.
        framed = files_matching(r"\{[^{}]*kModelMagic[^{}]*serializeModel|\{[^{}]*kModelMagic,\s*\"", "src", "include")
        self.assertEqual(framed, {"src/forest/model_io.cpp"})


if __name__ == "__main__":
    unittest.main()
