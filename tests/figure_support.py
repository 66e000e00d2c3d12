"""Helpers of the figure tests: the size of a PNG, PDF or SVG file, read from the file itself."""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(data: bytes) -> tuple[int, int]:
    """(width, height) in pixels from the IHDR chunk, after checking the signature and chunk type."""
    assert data[:8] == PNG_SIGNATURE
    length, kind = struct.unpack(">I4s", data[8:16])
    assert kind == b"IHDR" and length == 13
    return struct.unpack(">II", data[16:24])


def pdf_size(data: bytes) -> tuple[float, float]:
    """(width, height) in points from the single page's MediaBox, after checking the header/trailer."""
    assert data.startswith(b"%PDF-") and data.rstrip().endswith(b"%%EOF")
    boxes = re.findall(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", data)
    assert len(boxes) == 1
    return float(boxes[0][0]), float(boxes[0][1])


def svg_size(data: bytes) -> tuple[float, float]:
    """(width, height) in points of the root <svg> element (parsed as XML)."""
    root = ET.fromstring(data)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    width, height = root.get("width"), root.get("height")
    assert width.endswith("pt") and height.endswith("pt")
    return float(width[:-2]), float(height[:-2])
