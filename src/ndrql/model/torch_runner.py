"""The torch backend of the Predictor: an eager forward pass on a set number of threads (torch imported lazily)."""

from __future__ import annotations

import contextlib
from typing import Iterator

import numpy as np


@contextlib.contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run torch ops on ``n`` threads inside the block (0 = leave as is), restoring the count after."""
    import torch  # lazy: torch is optional

    before = torch.get_num_threads()
    if n and n != before:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if n and n != before:
            torch.set_num_threads(before)


class TorchRunner:
    """Eager torch forward: inference_mode, channels_last, fp32, on ``threads`` threads (restored after)."""

    name = "torch"

    def __init__(self, model, threads: int):
        import torch  # lazy: torch is optional

        self.model = model.eval().to(memory_format=torch.channels_last)
        self.threads = threads

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        import torch  # lazy: torch is optional

        with torch_threads(self.threads), torch.inference_mode():
            t = torch.from_numpy(np.ascontiguousarray(x, np.float32)).contiguous(memory_format=torch.channels_last)
            region, guide, *dist = self.model(t)
        r = torch.sigmoid(region)[:, 0].numpy()
        g = torch.sigmoid(guide)[:, 0].numpy() if guide is not None else None
        return r, g, (dist[0][:, 0].float().numpy() if dist else None)
