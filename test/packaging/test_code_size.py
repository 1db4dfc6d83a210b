"""No .cpp under src/ over 450 lines, no function over 100 lines outside src/sim/, no
class whose member functions are defined in more than one .cpp.

Functions are scanned in src/ and in the public headers under include/.

Long files and long functions are where concerns pile up unseen; these limits
(written in the session's style notes) held once by splitting, and this keeps
them (issue 41 lowered them from 500 and 120, splitting by concept what sat
just under those). A function is measured from the line its header starts on
to the line of its closing brace. The scan is a brace matcher over the code with comments,
strings and character literals blanked: a `{` at namespace or class level opens
a function body when the text since the previous declaration has a parameter
list before any `=` (so `const T kTable[] = {...}` is no function), and a
namespace, class, struct, union or enum body is walked into. The .clang-format
style keeps those headers regular enough for this.

A class whose members are defined in several .cpp files was cut by size rather
than by concept (issue 41): each concept then hides behind the one class's
private state. A member is a function whose qualified name's qualifier (`A::B`
for `A::B::f`) names a class or struct defined under include/ or src/, so a
namespace-qualified free function (`cli::f`) does not count.
"""
import pathlib
import re
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
MAX_FILE_LINES = 450
MAX_FUNCTION_LINES = 100
# The procedurally generated room is exempt from the function limit: its long
# builders are tables of furniture written as code.
FUNCTION_LIMIT_EXEMPT = ("src/sim/",)
# Known exceptions, as (file, function name). Each needs a reason and an owner.
KNOWN_LONG_FUNCTIONS = set()
CPP_SUFFIXES = (".cpp", ".h", ".hpp")
SCOPE_KEYWORD = re.compile(r"(?:^|[\s>;}])(namespace|class|struct|union|enum)\b")
NAME_BEFORE_PARAMS = re.compile(r"((?:~\s*)?[A-Za-z_]\w*(?:\s*<[^<>(){};]*>)?"
                                r"(?:\s*::\s*~?\s*[A-Za-z_]\w*(?:\s*<[^<>(){};]*>)?)*)\s*\($")
# A constructor's initializer list: a single `:` after the parameter list.
INITIALIZER_LIST = re.compile(r"\)[^(){};]*(?<!:):(?!:)")


def blank_comments_and_literals(text):
    """The text with comments, string and character literals replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            out.append(" " * (end - i))
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            open_paren = text.find("(", i)
            delimiter = text[i + 2:open_paren]
            end = text.find(")" + delimiter + '"', open_paren)
            end = n if end < 0 else end + len(delimiter) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif c in "\"'":
            # A digit separator (1'000'000) is no character literal.
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(c)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            end = min(j + 1, n)
            out.append(c + " " * (end - i - 2) + c if end - i >= 2 else " ")
            i = end
        else:
            out.append(c)
            i += 1
    return "".join(out)


def blank_preprocessor(text):
    """Preprocessor lines (with their continuations) blanked: they are no declarations."""
    lines = text.split("\n")
    continued = False
    for index, line in enumerate(lines):
        if continued or line.lstrip().startswith("#"):
            continued = line.rstrip().endswith("\\")
            lines[index] = ""
    return "\n".join(lines)


def function_name(header):
    """The name of the function whose header (text before its body) this is, or None."""
    depth = 0
    # The parameter list is the first parenthesis at depth 0 of the header, after
    # any template<...> prefix; an `=` before it makes the header an initializer.
    header = re.sub(r"^\s*template\s*<[^{};]*?>\s*", "", header)
    for index, c in enumerate(header):
        if c == "(" and depth == 0:
            before = header[:index + 1]
            if "=" in re.sub(r"\boperator\s*[^\s(]+", "operator", before):
                return None
            match = NAME_BEFORE_PARAMS.search(before)
            # An operator's name is no identifier; it is a function all the same.
            return re.sub(r"\s+", "", match.group(1) if match else before.split()[-1][:-1])
        if c == "<":
            depth += 1
        elif c == ">" and depth > 0:
            depth -= 1
    return None


def functions(text):
    """(name, first line, last line) of every function body at namespace or class level."""
    code = blank_preprocessor(blank_comments_and_literals(text))
    found = []
    scopes = []  # one entry per open brace: True when declarations (namespace, class) live inside
    header_start = 0
    i, n = 0, len(code)
    while i < n:
        c = code[i]
        at_declaration_level = all(scopes)
        if c == "{" and at_declaration_level:
            header = code[header_start:i]
            if INITIALIZER_LIST.search(header) and re.search(r"\w\s*$", header):
                # `member_{value}` in a constructor's initializer list, not its body.
                i = matching_brace(code, i) + 1
                continue
            name = None if SCOPE_KEYWORD.search(header.split("(")[0]) else function_name(header)
            if name is None:
                # A namespace or class body holds declarations; an initializer does not.
                is_scope = bool(SCOPE_KEYWORD.search(header.split("(")[0]))
                scopes.append(is_scope)
                header_start = i + 1
            else:
                close = matching_brace(code, i)
                first = code.count("\n", 0, header_start + len(header) - len(header.lstrip())) + 1
                found.append((name, first, code.count("\n", 0, close) + 1))
                i = close + 1
                header_start = i
                continue
        elif c == "{":
            scopes.append(False)
        elif c == "}":
            if scopes:
                scopes.pop()
            if all(scopes):
                header_start = i + 1
        elif c == ";" and at_declaration_level:
            header_start = i + 1
        elif c == ":" and at_declaration_level and re.search(
                r"\b(public|private|protected)\s*$", code[header_start:i]):
            header_start = i + 1
        i += 1
    return found


CLASS_DEFINITION = re.compile(r"(?<!enum )\b(?:class|struct)\s+(?:[A-Za-z_]\w*\s*::\s*)*([A-Za-z_]\w*)"
                              r"\s*(?:final\s*)?[:{]")
NAMESPACE_DEFINITION = re.compile(r"\bnamespace\s+([A-Za-z_]\w*)")


def class_names(texts):
    """Names of the classes and structs defined (not just declared) in the texts, and of the
    namespaces they open."""
    classes, namespaces = set(), set()
    for text in texts:
        code = blank_preprocessor(blank_comments_and_literals(text))
        classes.update(CLASS_DEFINITION.findall(code))
        namespaces.update(NAMESPACE_DEFINITION.findall(code))
    return classes, namespaces


def member_class(function, classes, namespaces):
    """The class `function` is a member of (`A::B` for `A::B::f`), or None for a free function."""
    parts = re.sub(r"<[^<>]*>", "", function).split("::")
    if len(parts) < 2 or parts[-2] not in classes or parts[0] in namespaces - classes:
        return None
    return "::".join(parts[:-1])


def matching_brace(code, open_index):
    depth = 0
    for index in range(open_index, len(code)):
        if code[index] == "{":
            depth += 1
        elif code[index] == "}":
            depth -= 1
            if depth == 0:
                return index
    raise AssertionError(f"unbalanced braces after offset {open_index}")


def source_files(suffixes, folders=("src",)):
    for folder in folders:
        for path in sorted((SOURCE / folder).rglob("*")):
            if path.is_file() and path.suffix in suffixes:
                yield path


def relative(path):
    return path.relative_to(SOURCE).as_posix()


class ScannerTest(unittest.TestCase):
    """The scan finds functions where the style puts them, and nothing else."""

    def test_finds_free_functions_methods_and_skips_initializers(self):
        text = "\n".join([
            '#include "x.h"',
            "namespace a {",
            "namespace {",
            "const int kTable[] = {1, 2,",
            "                      3};",
            "int helper(int x) {",
            '  const char* s = "}";  // }',
            "  return x;",
            "}",
            "}  // namespace",
            "struct Holder : public Base {",
            " public:",
            "  int get() const { return 1; }",
            "  Holder() : a_{1}, b_(2) {}",
            "};",
            "enum class Kind { kA, kB };",
            "const auto kTwice = [](int x) { return 2 * x; };",
            "template <typename T>",
            "std::vector<T> Holder::Many<T>::make(",
            "    int count) const {",
            "  if (count) {",
            "  }",
            "  return {};",
            "}",
            "bool operator==(const A& a, const A& b) { return a.x == b.x; }",
            "}  // namespace a",
        ])
        self.assertEqual(class_names([text]), ({"Holder"}, {"a"}))
        classes, namespaces = {"Holder", "Impl"}, {"a", "cli"}
        self.assertEqual(member_class("Holder::Many<T>::make", {"Many"} | classes, namespaces),
                         "Holder::Many")
        self.assertEqual(member_class("Holder::Impl::scan", classes, namespaces), "Holder::Impl")
        self.assertIsNone(member_class("cli::putLearned", classes, namespaces))
        self.assertIsNone(member_class("helper", classes, namespaces))
        self.assertEqual(functions(text), [("helper", 6, 9), ("get", 13, 13), ("Holder", 14, 14),
                                           ("Holder::Many<T>::make", 18, 24),
                                           ("operator==", 25, 25)])

    def test_counts_lines_from_header_to_closing_brace(self):
        body = "\n".join(["  x();"] * 130)
        text = f"namespace n {{\n\nvoid Long::run(int a,\n              int b) {{\n{body}\n}}\n}}\n"
        self.assertEqual(functions(text), [("Long::run", 3, 135)])


class CodeSizeTest(unittest.TestCase):
    def test_no_cpp_file_over_the_limit(self):
        files = list(source_files((".cpp",)))
        self.assertGreater(len(files), 50, f"found only {len(files)} .cpp files under src/")
        long_files = [f"{relative(path)} ({len(path.read_text().splitlines())} lines)"
                      for path in files if len(path.read_text().splitlines()) > MAX_FILE_LINES]
        self.assertEqual(long_files, [], f"these .cpp files under src/ are over {MAX_FILE_LINES} "
                         "lines; split them by concern, moving whole functions")

    def test_no_function_over_the_limit(self):
        long_functions, known_seen, scanned = [], set(), 0
        # The package's code: src/ and the inline functions of its public headers.
        for path in source_files(CPP_SUFFIXES, ("src", "include")):
            name = relative(path)
            if name.startswith(FUNCTION_LIMIT_EXEMPT):
                continue
            for function, first, last in functions(path.read_text()):
                scanned += 1
                length = last - first + 1
                if length <= MAX_FUNCTION_LINES:
                    continue
                short_name = function.split("::")[-1]
                if (name, short_name) in KNOWN_LONG_FUNCTIONS:
                    known_seen.add((name, short_name))
                    continue
                long_functions.append(f"{name}:{first} {function} ({length} lines)")
        self.assertGreater(scanned, 500, f"the scan found only {scanned} functions")
        self.assertEqual(long_functions, [], f"these functions are over {MAX_FUNCTION_LINES} lines; "
                         "split them by concern, moving whole steps into named functions")
        stale = sorted(KNOWN_LONG_FUNCTIONS - known_seen)
        self.assertEqual(stale, [], "these known exceptions are no longer over the limit (or gone); "
                         "remove them from KNOWN_LONG_FUNCTIONS")

    def test_no_class_spread_over_two_cpp_files(self):
        classes, namespaces = class_names(
            path.read_text() for path in source_files(CPP_SUFFIXES, ("src", "include")))
        files_of = {}
        for path in source_files((".cpp",)):
            for function, _, _ in functions(path.read_text()):
                owner = member_class(function, classes, namespaces)
                if owner is not None:
                    files_of.setdefault(owner, set()).add(relative(path))
        self.assertIn("SyntheticRoom", files_of, "the scan found no member of SyntheticRoom")
        spread = [f"{owner}: {', '.join(sorted(files))}" for owner, files in sorted(files_of.items())
                  if len(files) > 1]
        self.assertEqual(spread, [], "these classes have member functions in more than one .cpp; "
                         "split them by concept into classes or free functions of their own")


if __name__ == "__main__":
    unittest.main()
