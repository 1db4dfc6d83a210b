"""docs/architecture.md names only files and symbols that exist.

The architecture notes are where a new engineer starts, and a name in them that
the code no longer has (a renamed cost, a moved header) sends them looking for
nothing. This reads every `backticked` token outside the fenced diagrams and
checks the ones that look like a path or a C++ name:

- a path (it contains '/' or ends in a source, script, launch, config or doc
  suffix) must exist relative to the repository root, to include/ or to
  include/relocalizer/ (`pose/refinement_costs.h`, as the headers are
  included). A bare file name must exist in src/ros/ in the ROS layer's section
  (its table names `node_inputs.h`), or beside a path named earlier in the same
  paragraph or table row (`room_layout.cpp` after `src/sim/room_builder.h`).
  `<placeholder>` stands for any text; paths above the repository
  (`../shared/...`) are not the repository's to check.
- a C++ name (CamelCase types like `KeyFrameFeed`, lowerCamel functions like
  `refinePose`, `kConstants`, snake_case with parentheses like `main()`, and
  each part of a qualified name like `PoseSolution::failed_refinements`) must
  occur as a word in some file under the source folders below. Names of other
  libraries (`Eigen::umeyama`) are theirs to keep.

The fenced diagrams write names loosely (`online/online_learner.cpp` for
src/online/online_learner.cpp, `ModelBuilder::add`), so in them a file name
must exist somewhere in the repository, and each name with an inner capital
(`TreeSamples`, `drawTreeSamples`) must occur as a word like any C++ name.
"""
import fnmatch
import pathlib
import re
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
DOC = SOURCE / "docs" / "architecture.md"
PATH_ROOTS = ("", "include", "include/relocalizer")
ROS_SECTION_START = "ROS layer (`src/ros/`"
ROS_FOLDER = "src/ros"
PATH_SUFFIXES = (".h", ".cpp", ".py", ".sh", ".test", ".launch", ".yaml", ".md")
SYMBOL_FOLDERS = ("include", "src", "test", "scripts", "config", "launch", "msg", "srv")
# Namespaces of the libraries the package uses: their names are not ours to check.
EXTERNAL_NAMESPACES = {"std", "Eigen", "ceres", "cv", "ros", "tf2", "image_geometry", "CLI"}
CAMEL_CASE = re.compile(r"[A-Z][A-Za-z0-9]*[a-z][A-Za-z0-9]*")
LOWER_CAMEL = re.compile(r"[a-z][a-z0-9]*[A-Z][A-Za-z0-9]*")
CALL = re.compile(r"([a-z][a-z0-9_]*)\([^()]*\)")


def paragraphs(text):
    """Blocks of prose (blank-line separated, fenced diagrams left out), with their first line."""
    block, start, fenced = [], 0, False
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
            line = ""
        if fenced or not line.strip():
            if block:
                yield start, block
            block = []
            continue
        if not block:
            start = number
        block.append(line)
    if block:
        yield start, block


def backticked(line):
    return re.findall(r"`([^`]+)`", line)


def is_path(token):
    return " " not in token and ("/" in token or token.endswith(PATH_SUFFIXES))


def path_exists(path, folders):
    """Whether `path` names an existing file or folder under one of `folders`."""
    if "<" in path:
        pattern = re.sub(r"<[^<>]*>", "*", path)
        for folder in folders:
            base = SOURCE / folder
            if any(fnmatch.fnmatch(candidate.relative_to(base).as_posix(), pattern)
                   for candidate in base.rglob("*")):
                return True
        return False
    return any((SOURCE / folder / path.rstrip("/")).exists() for folder in folders)


def symbol_parts(token):
    """The C++ names a token asks for, or [] when it does not look like C++."""
    token = re.sub(r"<[^<>]*>", "", token)  # template arguments
    call = CALL.fullmatch(token)
    if call:
        return [call.group(1)]
    if " " in token or not re.fullmatch(r"\w+(::\w+)*(\(\))?", token):
        return []
    parts = token.rstrip("()").split("::")
    if parts[0] in EXTERNAL_NAMESPACES:
        return []
    if len(parts) == 1 and not (CAMEL_CASE.fullmatch(parts[0]) or LOWER_CAMEL.fullmatch(parts[0])
                                or token.endswith("()")):
        return []  # a module, tool, topic or parameter name: prose, not C++
    return parts


def source_words():
    words = set()
    for folder in SYMBOL_FOLDERS:
        for path in (SOURCE / folder).rglob("*"):
            if not path.is_file() or path.resolve() == pathlib.Path(__file__).resolve():
                continue
            try:
                words.update(re.findall(r"\w+", path.read_text()))
            except UnicodeDecodeError:
                continue  # images, bags, fuzz corpora
    return words


def stale_names(text, words):
    """Every path and C++ name the text names that does not exist, as 'line N: `token` ...'."""
    stale = []
    in_ros_section = False
    for start, block in paragraphs(text):
        if any(line.startswith(ROS_SECTION_START) for line in block):
            in_ros_section = True
        elif block[0].startswith("#"):
            in_ros_section = False
        for offset, line in enumerate(block):
            # A table row is a paragraph of its own: its bare file names sit beside its paths.
            folders_seen = [] if line.startswith("|") else None
            for token in backticked(line):
                where = f"line {start + offset}: `{token}`"
                if is_path(token):
                    if token.startswith("../"):
                        continue
                    seen = folders_seen if folders_seen is not None else block_folders(block, line)
                    if "/" in token.rstrip("/") or token.endswith("/"):
                        if not path_exists(token, PATH_ROOTS):
                            stale.append(f"{where}: no such file or folder under "
                                         f"{', '.join(root or '.' for root in PATH_ROOTS)}")
                        seen.append(parent_folder(token))
                    else:
                        folders = ([ROS_FOLDER] if in_ros_section else []) + seen
                        if not path_exists(token, folders):
                            stale.append(f"{where}: no such file in "
                                         f"{', '.join(folders) or 'a folder named before it'}")
                    continue
                missing = [part for part in symbol_parts(token) if part not in words]
                if missing:
                    stale.append(f"{where}: {', '.join(missing)} occurs in no file under "
                                 f"{', '.join(SYMBOL_FOLDERS)}")
    return stale


def stale_diagram_names(text, words):
    """Files and C++ names in the fenced diagrams that do not exist, as 'line N: `token` ...'."""
    stale, fenced = [], False
    files = {path.name for folder in ("include", "src", "test", "scripts", "launch")
             for path in (SOURCE / folder).rglob("*") if path.is_file()}
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            continue
        for token in re.findall(r"[\w/]*\w\.(?:h|cpp)\b", line):
            if token.split("/")[-1] not in files:
                stale.append(f"line {number}: `{token}` (diagram): no such file in the repository")
        for token in re.findall(r"\b[A-Za-z_]\w*(?:::\w+)*", line):
            parts = token.split("::")
            if parts[0] in EXTERNAL_NAMESPACES:
                continue
            missing = [part for part in parts
                       if re.search(r"[a-z0-9][A-Z]", part) and part not in words]
            if missing:
                stale.append(f"line {number}: `{token}` (diagram): {', '.join(missing)} occurs in "
                             f"no file under {', '.join(SYMBOL_FOLDERS)}")
    return stale


def parent_folder(path):
    """The repository folder a path with '/' names its file in."""
    for root in PATH_ROOTS:
        candidate = SOURCE / root / path.rstrip("/")
        if candidate.exists():
            folder = candidate if candidate.is_dir() else candidate.parent
            return folder.relative_to(SOURCE).as_posix()
    return str(pathlib.PurePosixPath(path).parent)


def block_folders(block, line):
    """Folders of the paths named in a prose paragraph up to `line`."""
    folders = []
    for earlier in block[:block.index(line) + 1]:
        for token in backticked(earlier):
            if is_path(token) and "/" in token.rstrip("/") and not token.startswith("../"):
                folders.append(parent_folder(token))
            if earlier == line:
                break
    return folders


class ArchitectureDocTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.words = source_words()

    def test_doc_names_only_what_exists(self):
        text = DOC.read_text()
        self.assertGreater(len(re.findall(r"`[^`]+`", text)), 100,
                           f"{DOC} has too few backticked names for this check to mean anything")
        stale = stale_names(text, self.words) + stale_diagram_names(text, self.words)
        self.assertEqual(stale, [], f"{DOC.relative_to(SOURCE)} names what the code does not have; "
                         "correct the doc (or restore the name):\n" + "\n".join(stale))

    def test_finds_a_stale_name_of_each_kind(self):
        text = "\n".join([
            "The costs live in `pose/refinement_costs.h` (`PointToPointCost`, `refinePose`);",
            "`pose/no_such_header.h` and `NoSuchCostAnywhere`, `noSuchFunction`,",
            "`PoseSolution::no_such_member` and `no_such_call()` do not; `Eigen::umeyama`,",
            "`train`, `--bag` and `map -> odom` are not C++ names of ours.",
            "",
            "Private: `src/sim/room_builder.h` (boxes in `room_builder.cpp`, not `room_nope.cpp`).",
            "",
            "ROS layer (`src/ros/`, thin):",
            "",
            "| `node_inputs.h` | `no_such_ros_file.h` |",
        ])
        self.assertEqual([re.search(r"`([^`]+)`", entry).group(1)
                          for entry in stale_names(text, self.words)],
                         ["pose/no_such_header.h", "NoSuchCostAnywhere", "noSuchFunction",
                          "PoseSolution::no_such_member", "no_such_call()", "room_nope.cpp",
                          "no_such_ros_file.h"])

    def test_finds_a_stale_name_in_a_diagram(self):
        text = "\n".join([
            "```",
            "   forest: model_builder.h  |  ModelBuilder::add, then buildSurface (surface_model.h)",
            "   pose: no_such_solver.cpp |  ModelBuilder::noSuchStep, NoSuchSamples per tree",
            "```",
            "`NoSuchOutsideTheDiagram` is the backticked check's.",
        ])
        self.assertEqual([re.search(r"`([^`]+)`", entry).group(1)
                          for entry in stale_diagram_names(text, self.words)],
                         ["no_such_solver.cpp", "ModelBuilder::noSuchStep", "NoSuchSamples"])


if __name__ == "__main__":
    unittest.main()
