"""The YAML half of a ROS ``map_server`` map: its keys (size-capped, no key twice) and the image it names.

:func:`map_files` tells the output guard (:mod:`ndrql.io.guard`) which files reading a map opens.
"""

from __future__ import annotations

from pathlib import Path

from ndrql.errors import MapFormatError, brief
from ndrql.io.text import MAX_YAML_BYTES, load_yaml, read_capped

YAML_SUFFIXES = (".yaml", ".yml")


def ros_doc(path: Path) -> dict:
    """The mapping of a ROS map YAML: at most :data:`~ndrql.io.text.MAX_YAML_BYTES`, no key twice."""
    data = read_capped(path, "ROS map YAML", MAX_YAML_BYTES, MapFormatError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise MapFormatError(f"cannot parse ROS map YAML {path}: not UTF-8 text") from None
    doc = load_yaml(text, f"ROS map YAML {path}", MapFormatError)
    if not isinstance(doc, dict):
        raise MapFormatError(f"ROS map {path}: expected a mapping of keys, got {type(doc).__name__}")
    return doc


def ros_image(path: Path, doc: dict) -> Path:
    """The image file a ROS map YAML names (relative to the YAML's folder)."""
    image = doc.get("image")
    if not isinstance(image, str) or not image.strip() or "\0" in image:
        raise MapFormatError(f"ROS map {path}: 'image' must be a file name, got {brief(image)}")
    return Path(image) if Path(image).is_absolute() else path.parent / image


def map_files(path: str | Path) -> list[Path]:
    """The files reading the map ``path`` opens: the file itself, and a ROS YAML's image.

    For the output guard (:mod:`ndrql.io.guard`): a YAML that cannot be read names only itself
    (reading the map then reports what is wrong with it).
    """
    path = Path(path)
    if path.suffix.lower() not in YAML_SUFFIXES:
        return [path]
    try:
        return [path, ros_image(path, ros_doc(path))]
    except MapFormatError:
        return [path]
