"""The public surface of the core's headers, read with a few regular expressions.

The headers share one simple style (one declaration per statement, comments with //, structs
and classes at namespace scope, bodies of inline functions on one line or braced), which is
what lets a parser this small read them; test_mirror.py checks it still does.
"""
import os
import re

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
# struct/class NAME [final] [: bases] {   (a forward declaration "struct Impl;" has no brace)
TYPE_HEAD = re.compile(r"(?<!enum )\b(struct|class)\s+(\w+)\s*(?:final\s*)?(?::[^{;]*)?\{")
ENUM_HEAD = re.compile(r"\benum\s+(?:class\s+)?(\w+)\s*(?::\s*\w+\s*)?\{")
ACCESS = re.compile(r"^\s*(public|private|protected)\s*:", re.M)


def read_text(path):
    with open(path, encoding="utf-8") as file:
        return file.read()


def header_paths(include_dir):
    return sorted(os.path.join(include_dir, name) for name in os.listdir(include_dir) if name.endswith(".h"))


def _matching_brace(text, open_index):
    depth = 0
    for index in range(open_index, len(text)):
        if text[index] == "{":
            depth += 1
        elif text[index] == "}":
            depth -= 1
            if depth == 0:
                return index
    raise ValueError("unbalanced braces")


def _split_top_level(text, separator):
    """Splits at `separator` outside (), {}, <> and []."""
    parts, depth, start = [], 0, 0
    for index, char in enumerate(text):
        if char in "({<[":
            depth += 1
        elif char in ")}>]":
            depth -= 1
        elif char == separator and depth == 0:
            parts.append(text[start:index])
            start = index + 1
    parts.append(text[start:])
    return parts


def _statements(body):
    """The body's declarations at its own level; braced bodies of member functions and nested
    types are dropped, braced initialisers kept (they follow a name, not a parenthesis)."""
    statements, current, index = [], "", 0
    while index < len(body):
        char = body[index]
        if char == "{":
            end = _matching_brace(body, index)
            before = current.rstrip()
            if before.endswith(")") or re.search(r"\)\s*(const|override|final|noexcept|\s)*$", before) \
                    or re.match(r"\s*(struct|class|enum|union)\b", current):
                statements.append(before)  # a function definition or a nested type: no data member
                current = ""
                index = end + 1
                # a nested type's closing "};" or a function's optional ";"
                while index < len(body) and body[index] in " \t\n;":
                    index += 1
                continue
            current += body[index:end + 1]
            index = end + 1
            continue
        if char == ";":
            statements.append(current)
            current = ""
        else:
            current += char
        index += 1
    if current.strip():
        statements.append(current)
    return statements


def _data_members(statement):
    """Names of the data members a declaration statement declares ([] for anything else)."""
    text = " ".join(statement.split())
    if not text or re.match(r"(using|typedef|friend|static|template|struct|class|enum|union|virtual)\b", text):
        return []
    names = []
    for index, part in enumerate(_split_top_level(text, ",")):
        declarator = _split_top_level(part, "=")[0].strip()
        declarator = re.sub(r"\{.*\}$", "", declarator).strip()  # braced initialiser
        declarator = re.sub(r"(\[[^\]]*\])+$", "", declarator).strip()  # array extent
        if "(" in declarator or "operator" in declarator:
            return []  # a function or constructor
        match = re.search(r"(\w+)$", declarator)
        if not match or (index == 0 and " " not in declarator and "<" not in declarator and "::" not in declarator):
            return []  # a type and a name are needed in the first declarator
        names.append(match.group(1))
    return names


def public_types(path):
    """{type name: [public data members]} for every struct and class the header defines."""
    text = COMMENT.sub("", read_text(path))
    types = {}
    position = 0
    while True:
        head = TYPE_HEAD.search(text, position)
        if not head:
            break
        open_index = head.end() - 1
        end = _matching_brace(text, open_index)
        body = text[open_index + 1:end]
        public = head.group(1) == "struct"
        members = []
        # Walk access sections in order; nested types inside were dropped by _statements.
        pieces = ACCESS.split(body)
        sections = [(public, pieces[0])] + [(pieces[i] == "public", pieces[i + 1]) for i in range(1, len(pieces), 2)]
        for section_public, section in sections:
            for statement in _statements(section):
                if section_public:
                    members += _data_members(statement)
        types[head.group(2)] = members
        position = end + 1
    return types


def public_enums(path):
    text = COMMENT.sub("", read_text(path))
    enums = {}
    for head in ENUM_HEAD.finditer(text):
        end = _matching_brace(text, head.end() - 1)
        values = [re.match(r"\s*(\w+)", item).group(1) for item in text[head.end():end].split(",") if item.strip()]
        enums[head.group(1)] = values
    return enums


if __name__ == "__main__":
    import sys
    for path in header_paths(sys.argv[1]):
        print(os.path.basename(path))
        for name, members in public_types(path).items():
            print("   ", name, members)
        for name, values in public_enums(path).items():
            print("    enum", name, values)
