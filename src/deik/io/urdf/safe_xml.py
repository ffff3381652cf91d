"""A URDF file as safe XML: `read_xml(path)` -> the `<robot>` element, with the line numbers
that errors name.

The parser never fetches anything (no network, no DTD) and never expands entities, and a
DOCTYPE that declares entities is refused before parsing: entity tricks (billion laughs, a
reference to a local file) would otherwise blow up memory or read other files, and a URDF
needs none. Line endings are normalised to LF first, because libxml2 counts only LF as a new
line and a CR-only file would put every element on line 1.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from deik.errors import FileFormatError
from deik.io.files import FilePath, read_input

if TYPE_CHECKING:  # lxml loads only when a URDF is read
    from lxml import etree


def read_xml(path: FilePath) -> etree._Element:
    """The `<robot>` element (lxml) of the URDF file at `path`, comments dropped, line numbers
    kept. Unreadable, empty, binary, malformed or non-URDF files raise FileFormatError."""
    from lxml import etree

    source = str(path)
    data = read_input(path, "URDF")
    if not data.strip():
        raise FileFormatError(source, "the file is empty; a URDF file holds a <robot> element")
    if b"\0" in data:
        raise FileFormatError(source, "not a text URDF (XML) file: it holds NUL bytes")
    # XML reads CR LF and a lone CR as LF anyway, so this changes no value, only the line count
    data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    _refuse_entity_declarations(data, source)
    parser = etree.XMLParser(
        remove_comments=True, resolve_entities=False, no_network=True, huge_tree=False, load_dtd=False
    )
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as error:
        line = error.position[0] if error.position else None
        raise FileFormatError(source, f"not well-formed XML: {error.msg}", line=line) from None
    if root.tag != "robot":
        raise FileFormatError(source, f"the top element is <{root.tag}>, a URDF needs <robot>", line=root.sourceline)
    return root


def _refuse_entity_declarations(data: bytes, source: str) -> None:
    """Refuse `<!ENTITY` after a `<!DOCTYPE`, the only place XML allows a declaration: this
    catches every one (and, harmlessly, the same text in a comment of a file with a DOCTYPE)."""
    doctype = data.find(b"<!DOCTYPE")
    declaration = data.find(b"<!ENTITY", doctype) if doctype >= 0 else -1
    if declaration >= 0:
        raise FileFormatError(
            source,
            "the <!DOCTYPE> declares entities (<!ENTITY ...>), which deik refuses because they can expand "
            "to gigabytes or read other files; a URDF needs none: remove the DOCTYPE",
            line=data.count(b"\n", 0, declaration) + 1,
        )
