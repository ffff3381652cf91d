"""A URDF file as safe XML: `read_xml(path)` -> the `<robot>` element, with the line numbers
that errors name.

The parser never fetches anything (no network, no DTD) and never expands entities, and a
DOCTYPE that declares entities is refused before parsing: entity tricks (billion laughs, a
reference to a local file) would otherwise blow up memory or read other files, and a URDF
needs none. Line endings are normalised to LF first, because libxml2 counts only LF as a new
line and a CR-only file would put every element on line 1.

What other URDF readers take is read too (pybullet's and ROS's TinyXML take it): NUL bytes
padding the end of a file (pybullet's humanoid.urdf ends in one), blank lines or a byte-order
mark before the XML declaration, and a declaration of a version other than 1.0 (pybullet's
minitaur files say "0.0"; XML 1.1 differs from 1.0 in nothing a URDF writes), read as 1.0.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from deik.errors import FileFormatError
from deik.io.files import FilePath, read_input

if TYPE_CHECKING:  # lxml loads only when a URDF is read
    from lxml import etree

DECLARATION = re.compile(rb"<\?xml\s+version\s*=\s*([\"'])([^\"']*)\1")


def read_xml(path: FilePath) -> etree._Element:
    """The `<robot>` element (lxml) of the URDF file at `path`, comments dropped, line numbers
    kept. Unreadable, empty, binary, malformed or non-URDF files raise FileFormatError."""
    from lxml import etree

    source = str(path)
    data = _as_xml_1_0(read_input(path, "URDF").rstrip(b"\0"))
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


def _as_xml_1_0(data: bytes) -> bytes:
    """`data` with a byte-order mark dropped, the white space before an XML declaration moved
    after it (the lines keep their numbers) and the declaration's version, when it is not 1.0,
    made 1.0."""
    text = data.removeprefix(b"\xef\xbb\xbf")
    start = len(text) - len(text.lstrip())
    end = text.find(b"?>", start) + 2
    if not text.startswith(b"<?xml", start) or end < 2:
        return data
    declaration = text[start:end]
    version = DECLARATION.match(declaration)
    if version is not None and version.group(2) != b"1.0":
        declaration = declaration[: version.start(2)] + b"1.0" + declaration[version.end(2) :]
    return declaration + text[:start] + text[end:]


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
