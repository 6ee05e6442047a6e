"""The griffe extension of the API reference (mkdocs.yml: mkdocstrings, extensions). Three jobs:

1. ibvs.sim names the compiled classes by assignment (`Target = _sim.Target`, `Camera = CameraModel`), which griffe
   reads as attributes without a docstring. Each such assignment becomes an alias of the class the stub
   python/ibvs/_core.pyi declares, so the reference shows ibvs.sim.Target with its docstring and members, as
   help(ibvs.sim.Target) does.
2. Constants are documented, in ibvs's source, by a `#:` comment on the lines above them (the Sphinx convention),
   which griffe does not read: such a comment becomes the constant's docstring.
3. The docstrings of ibvs are plain text, as help() shows them: hanging indents, aligned columns, and `*`, `_` and
   `<` in formulas (f*, z*, world <- camera). Read as Markdown they would lose their layout and their asterisks.
   Each docstring's first paragraph becomes its summary, with Markdown's special characters escaped; the rest is
   shown as it is written, in a text block.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

NATIVE = "ibvs._core."
MARKDOWN_SPECIAL = re.compile(r"([\\`*_\[\]#])")  # escaped with a backslash; < > | as HTML entities
ENTITIES = {"<": "&lt;", ">": "&gt;", "|": "&#124;"}
CONSTANT = re.compile(r"^[A-Z_][A-Z0-9_]*\s*(:[^=]+)?=.*[^,({\[]\s*$")  # NAME = value, on one line


def _modules(module: griffe.Module):
    yield module
    for sub in module.modules.values():
        if not sub.is_alias:
            yield from _modules(sub)


def _objects(obj: griffe.Object):
    yield obj
    for member in obj.members.values():
        if not member.is_alias and (member.is_class or member.is_function or member.is_attribute):
            yield from _objects(member)


def comment_docstring(attribute: griffe.Object) -> str | None:
    """The `#:` comment lines right above an attribute's assignment (or above the group of one-line constants it
    ends), joined, or None."""
    try:
        lines = attribute.lines_collection[attribute.filepath]
    except (KeyError, TypeError):
        return None
    found: list[str] = []
    i = (attribute.lineno or 1) - 2
    while i >= 0 and CONSTANT.match(lines[i]):  # a group of one-line constants under one comment
        i -= 1
    while i >= 0 and lines[i].strip().startswith("#:"):
        found.insert(0, lines[i].strip()[2:].strip())
        i -= 1
    return " ".join(found) or None


def as_markdown(text: str) -> str:
    """A plain-text docstring as Markdown: the first paragraph escaped, the rest verbatim in a text block."""
    summary, _, rest = text.strip("\n").partition("\n\n")
    out = MARKDOWN_SPECIAL.sub(r"\\\1", " ".join(summary.split()))
    out = re.sub(r"[<>|]", lambda m: ENTITIES[m.group(0)], out)
    if rest.strip():
        out += "\n\n```text\n" + rest.rstrip() + "\n```"
    return out


class IbvsDocs(griffe.Extension):
    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        if pkg.name != "ibvs":
            return
        for module in _modules(pkg):
            for name, member in list(module.members.items()):
                if member.is_alias or not member.is_attribute:
                    continue
                value = member.value
                named = isinstance(value, (griffe.ExprName, griffe.ExprAttribute))
                if named and value.canonical_path.startswith(NATIVE):
                    module.set_member(name, griffe.Alias(name, value.canonical_path, parent=module,
                                                         lineno=member.lineno, endlineno=member.endlineno))
        for module in _modules(pkg):
            for obj in _objects(module):
                if obj.is_attribute and obj.docstring is None:
                    text = comment_docstring(obj)
                    if text:
                        obj.docstring = griffe.Docstring(text, parent=obj)
                if obj.docstring is not None and not getattr(obj.docstring, "_ibvs_markdown", False):
                    obj.docstring.value = as_markdown(obj.docstring.value)
                    obj.docstring._ibvs_markdown = True

    on_package_loaded = on_package  # griffe < 2
