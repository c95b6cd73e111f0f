"""Output files, in one place: the atomic writer, JSON, NPZ, figures, folders, digests and the cache root.

Every file ndrql writes (maps, JSON reports, figures, arrays, checkpoints, caches, ONNX exports)
goes through :func:`atomic_write`, which behaves like a careful Unix tool:

- a regular file is replaced atomically: the data goes to a temporary file in the target's folder,
  is flushed to disk (``fsync``) and renamed over the target, so a reader sees the old file or the
  whole new one, never a part. On Linux the temporary file is anonymous (``O_TMPFILE``) until it
  is complete, so not even ``kill -9`` leaves a half-written file behind; elsewhere a named
  temporary file is removed on any error, and ones left by killed processes are swept up by the
  next write of the same file;
- a symlink at the name is refused (a rename would replace the link, and writing through it could
  reach any file), except the kernel's own links (``/dev/stdout``); a symlink planted while the run
  worked is refused at the final rename, never followed;
- a file the run reads (its input set, :mod:`ndrql.io.readset`: the map, the weights, presets,
  ONNX graphs, caches read) and any file of the installed package are refused;
- an existing FIFO, character device (``/dev/null``, a terminal) or other non-regular file is
  written directly, never replaced; a directory or socket in the way is an error;
- a new file gets ``0666 & ~umask`` permissions (like ``>`` in a shell), a replaced file keeps its
  mode; missing parent folders are created;
- every failure is one :class:`~ndrql.errors.OutputError` line and leaves no temporary file.

The package writes JSON, NPZ and figures through it and names data by content
(:func:`file_digest`, :func:`data_digest`): :mod:`ndrql.io.atomic` holds the writer,
:mod:`ndrql.io.formats` the rest; import both from here.

Layering: this package sits at the bottom. It imports the standard library and :mod:`ndrql.errors`
only (numpy and matplotlib objects are only handled when passed in), so any layer may use it.
"""

from ndrql.errors import OutputError
from ndrql.io.atomic import atomic_path, atomic_write, check_writable, make_folder, open_log, write_bytes, write_text
from ndrql.io.locks import folder_lock
from ndrql.io.readset import note_input, run_inputs
from ndrql.io.formats import cache_dir, data_digest, file_digest, json_text, save_figure, save_npz, to_jsonable, write_json

__all__ = [
    "OutputError",
    "atomic_path",
    "atomic_write",
    "cache_dir",
    "check_writable",
    "data_digest",
    "file_digest",
    "folder_lock",
    "json_text",
    "make_folder",
    "note_input",
    "open_log",
    "run_inputs",
    "save_figure",
    "save_npz",
    "to_jsonable",
    "write_bytes",
    "write_json",
    "write_text",
]
