"""The elements of a model file (MJCF or URDF) with their attributes and lines, as the file is
written (no defaults applied, no includes followed): what the defects and the known limitations
point at in the file (``defects``, ``known_limitations``)."""

from __future__ import annotations

import xml.parsers.expat
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from harness.model.input_files import model_format, read_input_bytes


@dataclass(frozen=True)
class XmlElement:
    tag: str
    attrs: dict
    line: int
    parent: int   # index of the parent element, -1 for the root


@cache
def elements(path: Path) -> tuple[XmlElement, ...]:
    """Every element of an XML file with its attributes, line and parent, in document order."""
    out: list[XmlElement] = []
    stack: list[int] = []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag, attrs):
        out.append(XmlElement(tag, dict(attrs), parser.CurrentLineNumber, stack[-1] if stack else -1))
        stack.append(len(out) - 1)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(read_input_bytes(path, model_format(path)), True)
    except xml.parsers.expat.ExpatError:
        return ()
    return tuple(out)

