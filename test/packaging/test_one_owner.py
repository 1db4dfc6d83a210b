"""Facts that have one owner in the code stay with it (issue 41).

- TF: the node owns one tf2_ros::Buffer and one TransformListener and lends
  the buffer to its parts (src/ros/node/relocalizer_node.h). roscpp merges a
  process's subscriptions to one topic into one connection, so the master and
  `rosnode info` show the node once on /tf however many listeners it has; each
  listener still keeps its own cache and thread, and only the source tells.
- A model file is framed in one place (modelFileReplacement, model_io.cpp):
  every other writer goes through it rather than pairing kModelMagic with
  serialized bytes by hand.
- The node's parameters: each part takes its own settings (*_settings.h in
  src/ros/node); only the composition (relocalizer_node.h) and the reader of
  them all (node_params.cpp) see NodeParams, so no part depends on another's.
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


# A direct include of node_params.h, by any path to it.
NODE_PARAMS_INCLUDED = r'#\s*include\s*"([^"]*/)?node_params\.h"'
NODE_PARAMS_READERS = NODE_FILES | {"src/ros/node/node_params.cpp"}


def quoted_includes(path):
    """The files `path` includes by a path relative to its own folder."""
    for name in re.findall(r'#\s*include\s*"([^"]+)"', code_of(path)):
        included = (path.parent / name).resolve()
        if included.is_file():
            yield included


def headers_seeing(target, *folders):
    """The headers that include `target`, directly or through other headers."""
    headers = [p.resolve() for p in code_files(*folders) if p.suffix in (".h", ".hpp")]
    includes = {h: set(quoted_includes(h)) for h in headers}
    seeing, grew = {target.resolve()}, True
    while grew:
        grew = False
        for header, included in includes.items():
            if header not in seeing and included & seeing:
                seeing.add(header)
                grew = True
    return {str(h.relative_to(SOURCE)) for h in seeing} - {str(target.relative_to(SOURCE))}


class OneOwnerOfTheNodeParams(unittest.TestCase):
    def test_only_the_composition_includes_node_params(self):
        including = files_matching(NODE_PARAMS_INCLUDED, "src", "include")
        self.assertTrue(including, "no include of node_params.h found at all: the pattern is out of date")
        self.assertEqual(including - NODE_PARAMS_READERS, set(),
                         "a part includes node_params.h: give it its own settings (*_settings.h)")

    def test_no_part_sees_node_params_through_another(self):
        seeing = headers_seeing(SOURCE / "src/ros/node/node_params.h", "src", "include")
        self.assertIn("src/ros/node/relocalizer_node.h", seeing, "the include walk is out of date")
        self.assertEqual(seeing - NODE_FILES, set(),
                         "a part's header brings node_params.h with it: give the part its own settings")


if __name__ == "__main__":
    unittest.main()
