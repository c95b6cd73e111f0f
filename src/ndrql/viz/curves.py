"""Training curves like the paper's Fig. 6 (rows 1-2): steps and return per episode.

Every function draws on ``ax``, returns its artists and never calls ``show``.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np


def plot_episode_curve(ax: Any, values: Sequence[float], *, convergence_episode: int | None = None,
                       label: str | None = None, color: str | None = None, smooth: int = 1,
                       linewidth: float = 0.8) -> list[Any]:
    """Per-episode ``values`` (episode 1, 2, ...) with a grey dashed vertical line at convergence.

    ``convergence_episode`` is the 1-based count of training episodes at convergence (as in
    :class:`~ndrql.planning.results.PlanResult`); ``smooth`` > 1 draws a running mean over that many
    episodes instead of the raw values.
    """
    v = np.asarray(values, dtype=np.float64)
    if smooth > 1 and v.size >= smooth:
        v = np.convolve(v, np.ones(smooth) / smooth, mode="valid")
        x = np.arange(smooth, smooth + v.size)
    else:
        x = np.arange(1, v.size + 1)
    artists: list[Any] = list(ax.plot(x, v, color=color, linewidth=linewidth, label=label))
    if convergence_episode is not None:
        c = artists[0].get_color()
        artists.append(ax.axvline(convergence_episode, color="grey", linestyle="--", linewidth=1.0))
        artists.append(ax.annotate(f"{convergence_episode}", xy=(convergence_episode, 1.0),
                                   xycoords=("data", "axes fraction"), xytext=(2, -10),
                                   textcoords="offset points", fontsize=7, color=c))
    ax.set_xlabel("episode")
    return artists


def plot_training_curves(ax_steps: Any, ax_return: Any, records: dict[str, Any], *,
                         convergence_episode: int | None, label: str | None = None,
                         color: str | None = None, smooth: int = 1) -> list[Any]:
    """Steps per episode on ``ax_steps`` and return per episode on ``ax_return`` (dict from
    :meth:`EpisodeRecords.to_dict`), each with the dashed convergence line."""
    artists = plot_episode_curve(ax_steps, records["steps"], convergence_episode=convergence_episode,
                                 label=label, color=color, smooth=smooth)
    ax_steps.set_ylabel("steps per episode")
    artists += plot_episode_curve(ax_return, records["returns"], convergence_episode=convergence_episode,
                                  label=label, color=color, smooth=smooth)
    ax_return.set_ylabel("return per episode")
    return artists


def plot_validation_curve(ax: Any, hours: Sequence[float], f1: Sequence[float], *, label: str | None = None,
                          color: str | None = None) -> list[Any]:
    """NDR model learning curve: validation F1 (percent) at each epoch end against training hours."""
    return list(ax.plot(np.asarray(hours, float), np.asarray(f1, float), marker="o", markersize=3, color=color,
                        label=label, linewidth=1.0))
