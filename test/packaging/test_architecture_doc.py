"""docs/architecture.md names only files and symbols that exist.

The architecture notes are where a new engineer starts, and a name in them that
the code no longer has (a renamed cost, a moved header) sends them looking for
nothing. This reads every `backticked` token outside the fenced diagrams and
checks the ones that look like a path or a C++ name:

- a path (it contains '/' or ends in a source, script, launch, config or doc
  suffix) must exist relative to the repository root, to include/ or to
  include/relocalizer/ (`pose/refinement_costs.h`, as the headers are
  included). A bare file name must exist in a folder of src/ros/ (one per build
  target) in the ROS layer's section (its tables name `node_inputs.h`), or
  beside a path named earlier in the same paragraph or table row (`room_layout.cpp` after `src/sim/room_builder.h`).
  `<placeholder>` stands for any text; paths above the repository
  (`../shared/...`) are not the repository's to check.
- a C++ name (CamelCase types like `KeyFrameFeed`, lowerCamel functions like
  `refinePose`, `kConstants`, snake_case with parentheses like `main()`, and
  each part of a qualified name like `PoseSolution::failed_refinements`) must
  occur as a word in the code of src/ or include/ (comments and string
  literals left out: a name that survives only in a comment is gone), or in a
  file the same paragraph or table row names by its path (a test's name beside
  `test/unit/test_pose_solver.cpp`). In `Class::member` the member must occur
  in a file that defines the class (`class`/`struct`/`enum` Class, with a body),
  or be defined as `Class::member` somewhere: a method that moved to another
  class is stale even when its name lives on elsewhere. Names of other
  libraries (`Eigen::umeyama`) are theirs to keep.

The fenced diagrams write names loosely (`online/online_learner.cpp` for
src/online/online_learner.cpp, `ModelBuilder::add`), so in them a file name
must exist somewhere in the repository, and each name with an inner capital
(`TreeSamples`, `drawTreeSamples`) must occur in the code as a backticked
C++ name does (`ModelBuilder::add`'s member in `ModelBuilder`'s files).
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
# The ROS layer's folders, one per build target (node, bag, replay, conversion).
ROS_FOLDERS = sorted(path.relative_to(SOURCE).as_posix()
                     for path in (SOURCE / ROS_FOLDER).iterdir() if path.is_dir())
PATH_SUFFIXES = (".h", ".cpp", ".py", ".sh", ".test", ".launch", ".yaml", ".md")
# Where the names a doc gives as C++ must live; a name used only by a test or a script counts
# where the doc names that file beside it.
CODE_FOLDERS = ("include", "src")
CODE_SUFFIXES = (".h", ".hpp", ".cpp")
# A comment or a string literal, matched from its start so that "//" inside a string or
# a quote inside a comment is read as what it is.
COMMENT_OR_STRING = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'',
                               re.S)
# Namespaces of the libraries the package uses: their names are not ours to check.
EXTERNAL_NAMESPACES = {"std", "Eigen", "ceres", "cv", "ros", "tf2", "image_geometry", "CLI"}
# Words with an inner capital that the diagrams use as prose, not as C++ names.
DIAGRAM_PROSE = {"OpenCV", "NaN"}
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


def code_text(path):
    """A file's text; for C++, without its comments and string literals."""
    try:
        text = path.read_text()
    except (UnicodeDecodeError, OSError):
        return ""  # images, bags, fuzz corpora
    if path.suffix in CODE_SUFFIXES:
        text = COMMENT_OR_STRING.sub(lambda m: " " if m.group(0)[0] == "/" else '""', text)
    return text


class Code:
    """The names the code of src/ and include/ has: its words, which files define each
    class, struct or enum, and the `Class::member` it spells out."""

    def __init__(self):
        self.texts = {path: code_text(path) for folder in CODE_FOLDERS
                      for path in sorted((SOURCE / folder).rglob("*"))
                      if path.is_file() and path.suffix in CODE_SUFFIXES}
        self.words = set()
        self.qualified = set()
        self.definers = {}
        for path, text in self.texts.items():
            self.words.update(re.findall(r"\w+", text))
            self.qualified.update(re.findall(r"\b(\w+)\s*::\s*(~?\w+)", text))
            for name in re.findall(r"\b(?:class|struct|enum(?:\s+class)?)\s+(?:\[\[[^]]*\]\]\s*)?"
                                   r"(\w+)(?:\s+final)?\s*(?::[^;{()]*)?\{", text):
                self.definers.setdefault(name, set()).add(path)

    def missing(self, parts, files=()):
        """The parts of a (qualified) name the code lacks; `files` are named beside it."""
        words = set(self.words)
        for path in files:
            words.update(re.findall(r"\w+", code_text(path)))
        missing = [part for part in parts if part not in words]
        for owner, member in zip(parts, parts[1:]):
            if member in missing or owner in missing or (owner, member) in self.qualified:
                continue
            if not any(re.search(rf"\b{member}\b", self.texts[path])
                       for path in self.definers.get(owner, ())):
                missing.append(f"{member} (not a member of {owner})")
        return missing


def named_files(tokens, folders):
    """The existing files that path tokens name (bare names: in `folders`)."""
    files = []
    for token in tokens:
        if not is_path(token) or token.startswith("../") or "<" in token:
            continue
        roots = PATH_ROOTS if "/" in token.rstrip("/") else folders
        files += [SOURCE / root / token for root in roots if (SOURCE / root / token).is_file()]
    return files


def stale_names(text, code):
    """Every path and C++ name the text names that does not exist, as 'line N: `token` ...'."""
    stale = []
    in_ros_section = False
    for start, block in paragraphs(text):
        if any(line.startswith(ROS_SECTION_START) for line in block):
            in_ros_section = True
        elif block[0].startswith("#"):
            in_ros_section = False
        ros = ROS_FOLDERS if in_ros_section else []
        prose = [line for line in block if not line.startswith("|")]
        prose_tokens = [token for line in prose for token in backticked(line)]
        prose_files = named_files(prose_tokens, ros + block_folders(prose, prose[-1])) if prose else []
        for offset, line in enumerate(block):
            # A table row is a paragraph of its own: its bare file names sit beside its paths.
            folders_seen = [] if line.startswith("|") else None
            if line.startswith("|"):
                tokens = backticked(line)
                folders = ros + [parent_folder(t) for t in tokens
                                 if is_path(t) and "/" in t.rstrip("/") and not t.startswith("../")]
                files_beside = named_files(tokens, folders)
            else:
                files_beside = prose_files
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
                        folders = ros + seen
                        if not path_exists(token, folders):
                            stale.append(f"{where}: no such file in "
                                         f"{', '.join(folders) or 'a folder named before it'}")
                    continue
                missing = code.missing(symbol_parts(token), files_beside)
                if missing:
                    stale.append(f"{where}: {', '.join(missing)}: not in the code of "
                                 f"{', '.join(CODE_FOLDERS)} nor in a file named beside it")
    return stale


def stale_diagram_names(text, code):
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
            if parts[0] in EXTERNAL_NAMESPACES or token in DIAGRAM_PROSE:
                continue
            if not any(re.search(r"[a-z0-9][A-Z]", part) for part in parts):
                continue
            missing = code.missing(parts)
            if missing:
                stale.append(f"line {number}: `{token}` (diagram): {', '.join(missing)}: not in "
                             f"the code of {', '.join(CODE_FOLDERS)}")
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


def documented_links(text):
    """{executable: {module}} from the diagram's `executables` block ('a, b --> m, n (why)')."""
    lines = text.split("\nexecutables\n", 1)[1].split("```", 1)[0].splitlines()
    links = {}
    for line in lines:
        for entry in re.split(r"\s{2,}", line.strip()):
            if "-->" not in entry:
                continue
            names, modules = entry.split("-->")
            modules = {m.strip() for m in re.sub(r"\(.*?\)", "", modules).split(",")}
            for name in names.split(","):
                links[name.strip()] = modules
    return links


def cmake_links():
    """{executable: {module}} as CMakeLists.txt links them (relocalizer_<module> libraries)."""
    cmake = (SOURCE / "CMakeLists.txt").read_text()
    found = {m.group(1): m.group(2) for m in re.finditer(r"relocalizer_tool\((\w+) ([^)]*)\)", cmake)}
    for target in ("relocalizer_node", "replay_evaluator"):
        found[target] = re.search(rf"target_link_libraries\({target} ([^)]*)\)", cmake).group(1)
    # Every unit test links the support library, which links the modules they use.
    found["unit tests"] = re.search(r"target_link_libraries\(unit_test_support PUBLIC ([^)]*)\)",
                                    cmake).group(1)
    found["rostest nodes"] = re.search(r"target_link_libraries\(\$\{name\} ([^)]*)\)",
                                       cmake).group(1)
    return {name: set(re.findall(r"\brelocalizer_(\w+)", libraries))
            for name, libraries in found.items()}


def flagged(lines, check, code):
    """The names `check` finds stale in the doc text made of `lines`, in order."""
    return [re.search(r"`([^`]+)`", entry).group(1) for entry in check("\n".join(lines), code)]


class ArchitectureDocTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.code = Code()

    def test_doc_names_only_what_exists(self):
        text = DOC.read_text()
        self.assertGreater(len(re.findall(r"`[^`]+`", text)), 100,
                           f"{DOC} has too few backticked names for this check to mean anything")
        stale = stale_names(text, self.code) + stale_diagram_names(text, self.code)
        self.assertEqual(stale, [], f"{DOC.relative_to(SOURCE)} names what the code does not have; "
                         "correct the doc (or restore the name):\n" + "\n".join(stale))

    def test_finds_a_stale_name_of_each_kind(self):
        lines = [
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
        ]
        self.assertEqual(flagged(lines, stale_names, self.code),
                         ["pose/no_such_header.h", "NoSuchCostAnywhere", "noSuchFunction",
                          "PoseSolution::no_such_member", "no_such_call()", "room_nope.cpp",
                          "no_such_ros_file.h"])

    def test_executables_link_what_the_doc_draws(self):
        documented, linked = documented_links(DOC.read_text()), cmake_links()
        wrong = [f"{name}: the doc draws {sorted(documented.get(name, []))}, CMakeLists.txt "
                 f"links {sorted(linked.get(name, []))}"
                 for name in sorted(set(documented) | set(linked))
                 if documented.get(name) != linked.get(name)]
        self.assertEqual(wrong, [], f"{DOC.relative_to(SOURCE)}'s executables block is not "
                         "what CMakeLists.txt links:\n" + "\n".join(wrong))

    def test_names_every_public_header_and_every_ros_header(self):
        text = DOC.read_text()
        named = set(backticked(text)) | set(re.findall(r"[\w/]*\w\.h\b", text))
        headers = [path.relative_to(SOURCE / "include" / "relocalizer").as_posix()
                   for path in sorted((SOURCE / "include" / "relocalizer").rglob("*.h"))]
        headers += [path.name for path in sorted((SOURCE / ROS_FOLDER).rglob("*.h"))]
        unnamed = [header for header in headers if header not in named]
        self.assertEqual(unnamed, [], f"{DOC.relative_to(SOURCE)} does not say what these "
                         "headers hold (the Files tables):\n" + "\n".join(unnamed))

    def test_finds_a_name_that_lives_only_in_comments_or_in_another_class(self):
        lines = [
            # KinectFusion: a word of comments in src/ (the reference poses), of no code.
            "`KinectFusion` and `HintPrior::relocalize` (a member of another class),",
            "`HintPrior::factor`, `PlaceSet::relocalize` and `Relocalization::point_inlier_world`",
            "are; `HandDerivedJacobiansMatchAutodiff` is a test's, named beside its file",
            "`test/unit/test_pose_solver.cpp`.",
            "",
            "`HandDerivedJacobiansMatchAutodiff` without its file is not the code's.",
        ]
        self.assertEqual(flagged(lines, stale_names, self.code),
                         ["KinectFusion", "HintPrior::relocalize",
                          "HandDerivedJacobiansMatchAutodiff"])

    def test_finds_a_stale_name_in_a_diagram(self):
        lines = [
            "```",
            "   forest: model_builder.h  |  ModelBuilder::add, then buildSurface (surface_model.h)",
            "   pose: no_such_solver.cpp |  ModelBuilder::noSuchStep, NoSuchSamples per tree",
            "   forest: ModelBuilder::relocalize (a member of another class) on OpenCV",
            "```",
            "`NoSuchOutsideTheDiagram` is the backticked check's.",
        ]
        self.assertEqual(flagged(lines, stale_diagram_names, self.code),
                         ["no_such_solver.cpp", "ModelBuilder::noSuchStep", "NoSuchSamples",
                          "ModelBuilder::relocalize"])


if __name__ == "__main__":
    unittest.main()
