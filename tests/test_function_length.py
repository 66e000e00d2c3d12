"""Functions a maintainer can hold in their head: every function in python/nightloc and in cpp/src is
at most MAX_LINES lines (its definition line through its last line), unless the comment block right
above its definition (above its decorators, or its template line) gives the reason:
``# long: <reason>`` or ``// long: <reason>``;
in the files of HARD_LIMIT_FILES none is over HARD_LIMIT lines, whatever the reason
(docs/design.md, conventions)."""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYTHON = ROOT / "python" / "nightloc"
CPP = ROOT / "cpp" / "src"
#: Lines a function may have without a reason written beside it.
MAX_LINES = 80
#: Lines no function of HARD_LIMIT_FILES may have.
HARD_LIMIT = 100
HARD_LIMIT_FILES = ("cpp/src/localization/grid_filter.cpp", "python/nightloc/experience/learning.py")
PY_MARKER = re.compile(r"^\s*#\s*long:\s*\S")
CPP_MARKER = re.compile(r"^\s*//\s*long:\s*\S")
CPP_SUFFIXES = (".cpp", ".hpp", ".h", ".cc")


@dataclass(frozen=True)
class Function:
    """A function definition: its name, first line (1-based) and length in lines."""

    name: str
    line: int
    lines: int


def python_functions(source: str) -> list[Function]:
    """Every function and method of a module (nested ones too), from its ``def`` line to its last."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            assert node.end_lineno is not None
            found.append(Function(node.name, node.lineno, node.end_lineno - node.lineno + 1))
    return found


def python_marker_line(source: str, function: Function) -> int:
    """The line (1-based) where a function's reason belongs: above its first decorator or its def."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.lineno == function.line:
            return min([node.lineno] + [d.lineno for d in node.decorator_list]) - 1
    raise AssertionError(function)


def blank_comments_and_literals(source: str) -> str:
    """``source`` with comments, string and character literals (raw strings too) and preprocessor
    lines replaced by spaces, newlines kept: braces left are the code's."""
    out = []
    i, n = 0, len(source)
    line_start = True
    while i < n:
        c = source[i]
        if line_start and c == "#":  # a preprocessor line, with its continuations
            while i < n and source[i] != "\n":
                if source[i] == "\\" and i + 1 < n and source[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c == "\n":
            line_start = True
            out.append(c)
            i += 1
            continue
        if not c.isspace():
            line_start = False
        if source.startswith("//", i):
            end = source.find("\n", i)
            end = n if end < 0 else end
            out.append(" " * (end - i))
            i = end
            continue
        if source.startswith("/*", i):
            end = source.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", source[i:end]))
            i = end
            continue
        raw = re.match(r'(?:u8|[uUL])?R"([^()\\\s]{0,16})\(', source[i:])
        if raw and (i == 0 or not (source[i - 1].isalnum() or source[i - 1] == "_")):
            end = source.find(")" + raw.group(1) + '"', i + raw.end())
            end = n if end < 0 else end + len(raw.group(1)) + 2
            out.append('""' + re.sub(r"[^\n]", " ", source[i + 2 : end]))
            i = end
            continue
        if c in "\"'":
            if c == "'" and i > 0 and source[i - 1].isalnum() and i + 1 < n and source[i + 1].isalnum():
                out.append(" ")  # a digit separator (1'000'000)
                i += 1
                continue
            j = i + 1
            while j < n and source[j] != c and source[j] != "\n":
                j += 2 if source[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


# a namespace, class, struct, union or enum (its head may follow a macro invocation without a
# semicolon), or an extern "C" block
_SCOPE_KEYWORDS = re.compile(
    r"(?:^|[\s)])(?:namespace(?:\s+[\w:]+)?\s*$|(?:class|struct|union|enum)\b[^()]*$)|^extern\s*\"\"$", re.S
)
_ACCESS = re.compile(r"^(?:(?:public|private|protected)\s*:(?!:)\s*)+")
_INIT_LIST = re.compile(r"\)\s*(?:noexcept\s*)?:(?!:)")


def _balanced(text: str) -> bool:
    return text.count("(") == text.count(")")


def _is_function_head(head: str) -> bool:
    """Whether the text before a ``{`` at namespace or class scope opens a function body."""
    if "(" not in head or not _balanced(head) or _SCOPE_KEYWORDS.search(head):
        return False
    before_paren = head[: head.index("(")]
    return "=" not in before_paren or "operator" in before_paren


_NAME = re.compile(r"(operator\s*(?:\(\)|[^\s(]+)|~?[\w:~]+(?:<[^()]*>)?)\s*$")


def _declarator(head: str) -> tuple[str, int]:
    """A function head's name and where it starts in ``head``: the name before its parameter
    list (the group that ends at the last ``)`` before an init list and the qualifiers)."""
    init = _INIT_LIST.search(head)
    end = head.rfind(")", 0, init.start() + 1 if init else len(head))
    depth, k = 0, end
    while k >= 0:
        depth += {")": 1, "(": -1}.get(head[k], 0)
        if depth == 0:
            break
        k -= 1
    found = _NAME.search(head[:k])
    if not found:
        return "?", 0
    # a return type a template's arguments joined to the name: the name is the last piece
    pieces = re.split(r"[\s&*]+(?![^<]*>)", found.group(1))
    return pieces[-1], found.start(1) + found.group(1).rindex(pieces[-1])


def cpp_functions(source: str) -> list[Function]:
    """The function definitions at namespace and class scope of a C++ source (inline methods
    included, lambdas and local classes inside them part of their function), each from the line
    of its name to its closing brace."""
    code = blank_comments_and_literals(source)
    line_of = [0] * (len(code) + 1)
    line = 1
    for k, ch in enumerate(code):
        line_of[k] = line
        line += ch == "\n"
    line_of[len(code)] = line
    found: list[Function] = []
    scopes: list[str] = []  # "scope" (namespace, class), "body" (a function or an initializer)
    head_start = 0
    i = 0
    while i < len(code):
        ch = code[i]
        in_scope = not scopes or scopes[-1] == "scope"
        if ch == "{" and in_scope:
            head = code[head_start:i].strip()
            stripped = _ACCESS.sub("", head)
            prev = code[:i].rstrip()[-1:] if code[:i].rstrip() else ""
            if _INIT_LIST.search(stripped) and (prev.isalnum() or prev in "_>"):
                depth, i = 1, i + 1  # a member's brace initializer in a constructor's init list
                while i < len(code) and depth:
                    depth += {"{": 1, "}": -1}.get(code[i], 0)
                    i += 1
                continue
            if _is_function_head(stripped):
                offset = i - len(code[head_start:i].lstrip()) + len(head) - len(stripped)  # where stripped starts
                name, at = _declarator(stripped)
                depth, j = 1, i + 1
                while j < len(code) and depth:
                    depth += {"{": 1, "}": -1}.get(code[j], 0)
                    j += 1
                first = line_of[offset + at]
                found.append(Function(name, first, line_of[j - 1] - first + 1))
                i = j
                head_start = j
                continue
            scopes.append("scope" if _SCOPE_KEYWORDS.search(stripped) else "body")
            head_start = i + 1
        elif ch == "{":
            scopes.append("body")
        elif ch == "}":
            if scopes:
                scopes.pop()
            if not scopes or scopes[-1] == "scope":
                head_start = i + 1
        elif ch == ";" and in_scope:
            head_start = i + 1
        i += 1
    return found


def _python_files() -> list[Path]:
    return sorted(PYTHON.rglob("*.py"))


def _cpp_files() -> list[Path]:
    return sorted(p for p in CPP.rglob("*") if p.suffix in CPP_SUFFIXES)


def _has_reason(lines: list[str], above: int, marker: re.Pattern, comment: str) -> bool:
    """Whether the comment block that ends on line ``above`` (1-based) holds a ``long:`` reason."""
    while above >= 1 and lines[above - 1].lstrip().startswith(comment):
        if marker.match(lines[above - 1]):
            return True
        above -= 1
    return False


def _too_long(path: Path) -> list[str]:
    """This file's functions over the limits (see :func:`too_long_in`)."""
    return too_long_in(path.read_text(encoding="utf-8"), path.relative_to(ROOT).as_posix())


def too_long_in(source: str, relative: str) -> list[str]:
    """The functions of ``source`` (the file ``relative`` to the repository) over the limits: over
    HARD_LIMIT in a file of HARD_LIMIT_FILES, or over MAX_LINES without a reason above them."""
    lines = source.splitlines()
    is_python = relative.endswith(".py")
    functions = python_functions(source) if is_python else cpp_functions(source)
    problems = []
    for f in functions:
        if relative in HARD_LIMIT_FILES and f.lines > HARD_LIMIT:
            problems.append(f"{relative}:{f.line} {f.name}: {f.lines} lines (at most {HARD_LIMIT} in this file)")
            continue
        if f.lines <= MAX_LINES:
            continue
        above = python_marker_line(source, f) if is_python else f.line - 1
        while not is_python and above >= 1 and lines[above - 1].lstrip().startswith("template"):
            above -= 1  # a template's reason goes above its template line
        if not _has_reason(lines, above, PY_MARKER if is_python else CPP_MARKER, "#" if is_python else "//"):
            problems.append(
                f"{relative}:{f.line} {f.name}: {f.lines} lines; split it into named steps, or write the reason on "
                f"the comment above it: {'# long:' if is_python else '// long:'} <reason>"
            )
    return problems


@pytest.mark.parametrize("kind", ["python", "cpp"])
def test_functions_are_short_or_say_why(kind):
    files = _python_files() if kind == "python" else _cpp_files()
    assert files, f"no {kind} files found"
    problems = [problem for path in files for problem in _too_long(path)]
    assert not problems, "\n".join(problems)


def test_the_hard_limit_files_exist():
    for relative in HARD_LIMIT_FILES:
        assert (ROOT / relative).is_file(), relative


FIXTURE = r"""
#include <string>  // { not a brace
#define BLOCK(x) { x; }
namespace outer {
namespace {
constexpr int kTable[] = {1, 2, 3};
const char* kText = "}{";
int helper(int a) {
    const char c = '{';
    auto lambda = [&](int b) {
        if (b > 0) { return b; }  // }}}
        return 0;
    };
    return lambda(a) + c;
}
}  // namespace

/* a comment { with braces
   over lines } */
struct Point {
    int x{0}, y{0};
    int sum() const { return x + y; }
    Point() : x{1}, y(2) {
        x += 1;
    }
};

template <typename T>
T twice(T v) {
    const std::string raw = R"x(}{")x";
    return v + v;
}

extern "C" int c_entry(void) {
    return 1'000;
}

MACRO_WITHOUT_SEMICOLON(a, b)
namespace inner {
template <class T> struct Box : T {
    int open() { return 0; }
};
}  // namespace inner

bool operator==(const Point& a, const Point& b) { return a.x == b.x; }
}  // namespace outer
"""


def test_the_cpp_scanner_finds_functions_by_their_braces():
    found = {(f.name, f.line, f.lines) for f in cpp_functions(FIXTURE)}
    assert found == {
        ("helper", 8, 8),
        ("sum", 22, 1),
        ("Point", 23, 3),
        ("twice", 29, 4),
        ("c_entry", 34, 3),
        ("open", 41, 1),
        ("operator==", 45, 1),
    }


def test_a_reason_lets_a_long_function_be():
    body = "\n".join(f"    x += {k}" for k in range(MAX_LINES))
    source = f"def long_one(x):\n{body}\n    return x\n"
    assert [f.lines for f in python_functions(source)] == [MAX_LINES + 2]
    assert len(too_long_in(source, "a.py")) == 1
    marked = f"# long: a table of the scene's objects\n# (more words)\n@staticmethod\n{source}"
    assert too_long_in(marked, "a.py") == []
    assert too_long_in("# long:\n" + source, "a.py") != [], "a reason is words"
    cpp = "int long_one(int x) {\n" + "\n".join(f"    x += {k};" for k in range(MAX_LINES)) + "\n    return x;\n}\n"
    assert [f.lines for f in cpp_functions(cpp)] == [MAX_LINES + 3]
    assert len(too_long_in(cpp, "a.cpp")) == 1
    assert too_long_in("// long: a kernel's loop nest\ntemplate <class T>\n" + cpp, "a.cpp") == []
    longer = "int long_one(int x) {\n" + "\n".join(f"    x += {k};" for k in range(HARD_LIMIT)) + "\n}\n"
    assert too_long_in("// long: no reason is enough here\n" + longer, HARD_LIMIT_FILES[0]) != []
