"""ndrql tune reads only the shipped model's validation split of TRAIN: checked sample by sample."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

pytestmark = [pytest.mark.data]


def _hash(m: np.ndarray) -> str:
    return hashlib.sha1(m.tobytes()).hexdigest()


@pytest.mark.slow
def test_tuning_uses_only_validation_train_maps(dataset_root, model_weights, monkeypatch):
    pytest.importorskip("optuna")
    import ndrql.dataset.cache as cache
    import ndrql.dataset.layout as layout
    from ndrql.dataset.splits import train_val_split
    from ndrql.model.checkpoint import load_checkpoint
    from ndrql.tuning import objective

    tc = dict(load_checkpoint(model_weights).get("train_config", {}))
    assert (tc.get("val_fraction"), tc.get("seed")) == (0.05, 0)  # the split tuning reproduces
    train, seen, unseen = (cache.load_split(dataset_root, s, progress=False) for s in ("train", "seen", "unseen"))
    fit, val = train_val_split(train, seen, 0.05, 0)

    opened: list[str] = []
    real = cache.load_split

    def spy(root, split, *a, **kw):
        opened.append(split)
        return real(root, split, *a, **kw)

    def no_sample(*a, **kw):
        raise AssertionError("tuning decoded a dataset sample file")

    monkeypatch.setattr(cache, "load_split", spy)
    monkeypatch.setattr(layout, "load_sample", no_sample)
    ids = objective.validation_ids(dataset_root)
    assert list(ids) == sorted(val.tolist())
    problems, skipped, _ = objective.tuning_problems(dataset_root, 6, order_seed=0)
    assert set(opened) <= {"train", "seen"} and "unseen" not in opened  # SEEN only to rebuild the split's map set
    used = [int(p.key.split("-")[1]) for p in problems]
    assert all(p.key.startswith("train-") for p in problems) and len(used) == 6
    assert set(used) | set(skipped) <= set(val.tolist())
    assert not set(used) & set(fit.tolist())
    used_maps = {_hash(train.maps[train.map_index[i]]) for i in used}
    assert not used_maps & {_hash(m) for m in train.maps[np.unique(train.map_index[fit])]}  # no map the model trained on
    assert not used_maps & {_hash(m) for m in seen.maps} and not used_maps & {_hash(m) for m in unseen.maps}
    assert used == [i for i in objective.pick_samples(val, 0) if i not in skipped][:6]  # the seeded order
