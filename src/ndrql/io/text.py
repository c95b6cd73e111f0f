"""Small text inputs (ROS map YAML, presets, manifests) read with a size cap before parsing.

A parser's cost grows with its input (PyYAML takes about 20 s and 300 MB per MB of YAML), so the
size is checked from the file system before a byte is read, and the error says how big the file is
and what the limit is. YAML mappings with a key given twice are refused (PyYAML keeps the last
value without a word); JSON or YAML nested deeper than Python's recursion limit is one line, not a
traceback. Every failure is :class:`~ndrql.errors.NdrqlError` (or the subclass the caller names).

Layering: the standard library and :mod:`ndrql.errors`; PyYAML is imported only by
:func:`load_yaml` (lazy: a third-party library kept out of start-up).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ndrql.errors import NdrqlError

__all__ = ["MAX_TEXT_BYTES", "MAX_YAML_BYTES", "load_json", "load_yaml", "read_capped"]

MAX_YAML_BYTES = 64 * 1024
"""Largest YAML read (a ROS ``map_server`` YAML is a few hundred bytes)."""
MAX_TEXT_BYTES = 16 * 1024 * 1024
"""Largest JSON or other small text input read (presets, manifests, prediction records)."""


def _shown(path: Path) -> str:
    text = str(path)
    return text if text.isprintable() else repr(text)


def read_capped(path: str | os.PathLike, what: str, limit: int = MAX_TEXT_BYTES,
                error: type[NdrqlError] = NdrqlError) -> bytes:
    """The bytes of ``path`` when it is a regular file of at most ``limit`` bytes; ``error`` otherwise."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            st = os.fstat(fh.fileno())
            if st.st_size > limit:
                raise error(f"{what} {_shown(path)} is {st.st_size:,} bytes, more than the limit of {limit:,}; "
                            f"is it the right file?")
            data = fh.read(limit + 1)
    except FileNotFoundError:
        raise error(f"{what} not found: {_shown(path)}") from None
    except IsADirectoryError:
        raise error(f"{what} {_shown(path)} is a folder, not a file") from None
    except OSError as exc:
        raise error(f"cannot read {what} {_shown(path)}: {exc.strerror or type(exc).__name__}") from None
    if len(data) > limit:  # a FIFO or device reports no size
        raise error(f"{what} {_shown(path)} is more than the limit of {limit:,} bytes; is it the right file?")
    return data


def load_json(text: str | bytes, what: str, error: type[NdrqlError] = NdrqlError) -> Any:
    """Parse JSON; bad JSON or nesting deeper than the recursion limit is one ``error`` line."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{what} is not valid JSON (line {exc.lineno}: {exc.msg})") from None
    except (RecursionError, MemoryError):
        raise error(f"{what} is nested too deeply to read") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise error(f"{what} is not valid JSON ({type(exc).__name__})") from None


def _strict_loader() -> Any:
    """A ``yaml.SafeLoader`` subclass that refuses a mapping with a key given twice and reads ``010`` as 10
    (YAML 1.2, as ROS map_server does; PyYAML's YAML 1.1 reads it as octal 8)."""
    import yaml  # lazy: a third-party library, only for YAML inputs

    class StrictLoader(yaml.SafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            seen: set = set()
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode):
                    key = key_node.value
                    if key in seen:
                        line = key_node.start_mark.line + 1
                        raise yaml.constructor.ConstructorError(
                            None, None, f"the key {key[:40]!r} is given twice (line {line})", key_node.start_mark)
                    seen.add(key)
            return super().construct_mapping(node, deep=deep)

        def construct_yaml_int(self, node: Any) -> Any:
            """YAML 1.2's integers, as ROS map_server (yaml-cpp) reads them: ``010`` is 10, not octal 8."""
            text = str(self.construct_scalar(node)).replace("_", "")
            body = text.lstrip("+-")
            if body.isdigit():
                return -int(body) if text.startswith("-") else int(body)
            return super().construct_yaml_int(node)

    StrictLoader.add_constructor("tag:yaml.org,2002:int", StrictLoader.construct_yaml_int)
    return StrictLoader


def load_yaml(text: str, what: str, error: type[NdrqlError] = NdrqlError) -> Any:
    """Parse YAML safely (no objects), refusing duplicate keys; any failure is one ``error`` line."""
    import yaml  # lazy: a third-party library, only for YAML inputs

    try:
        return yaml.load(text, Loader=_strict_loader())  # noqa: S506 - a SafeLoader subclass
    except yaml.MarkedYAMLError as exc:
        problem = str(exc.problem or exc.context or "invalid YAML")[:200]
        where = f" (line {exc.problem_mark.line + 1})" if exc.problem_mark is not None and "line" not in problem else ""
        raise error(f"cannot parse {what}: {problem}{where}") from None
    except (yaml.YAMLError, RecursionError, MemoryError, ValueError) as exc:
        reason = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
        raise error(f"cannot parse {what}: {reason}") from None
