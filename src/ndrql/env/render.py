"""Drawing an environment's state: text (``ansi``) and an RGB image (``rgb_array``), shared by both envs."""

from __future__ import annotations

import numpy as np

Cell = tuple[int, int]

#: RGB colours of the ``rgb_array`` render.
COLOURS: dict[str, tuple[int, int, int]] = {
    "free": (255, 255, 255),
    "blocked": (40, 40, 40),
    "visited": (190, 215, 255),
    "start": (220, 40, 40),
    "goal": (40, 80, 220),
    "agent": (40, 170, 60),
}


def render_text(blocked: np.ndarray, visited: np.ndarray, agent: Cell, start: Cell, goal: Cell) -> str:
    """Rows of ``#`` blocked, ``.`` free, ``*`` visited, ``S``/``G`` start/goal and ``A`` the agent (on top)."""
    rows = [["#" if b else ("*" if v else ".") for b, v in zip(brow, vrow)] for brow, vrow in zip(blocked, visited)]
    for cell, ch in ((start, "S"), (goal, "G"), (agent, "A")):
        rows[cell[0]][cell[1]] = ch
    return "\n".join("".join(row) for row in rows) + "\n"


def render_rgb(blocked: np.ndarray, visited: np.ndarray, agent: Cell, start: Cell, goal: Cell, cell_px: int) -> np.ndarray:
    """``(h * cell_px, w * cell_px, 3)`` uint8 image in :data:`COLOURS`."""
    h, w = blocked.shape
    img = np.empty((h, w, 3), dtype=np.uint8)
    img[:] = COLOURS["free"]
    img[visited] = COLOURS["visited"]
    img[blocked] = COLOURS["blocked"]
    img[start] = COLOURS["start"]
    img[goal] = COLOURS["goal"]
    img[agent] = COLOURS["agent"]
    k = max(1, int(cell_px))
    return np.ascontiguousarray(np.repeat(np.repeat(img, k, axis=0), k, axis=1))
