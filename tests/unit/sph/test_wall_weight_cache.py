"""The baked wall-weight curves kept on disk: the same curves, reused, rebuilt when the key changes."""

import numpy as np

from erosim.sph.boundaries import wall_weight_harada2007 as ww


def test_cache_reused_and_rebuilt_when_the_kernel_changes(tmp_path, monkeypatch):
    args = ("wendland", 3, 0.02, 0.04, 1000.0, "artificial")
    first = ww.bake_cached(*args, folder=tmp_path)
    fresh = ww.bake(*args)
    assert np.array_equal(first.table, fresh.table) and first.dl == fresh.dl and first.approach_only
    assert first.table.shape[0] == ww.ROWS and np.any(first.table[ww.ATT] < 0)  # the attraction curve is baked too
    files = sorted(tmp_path.glob("*.npz"))
    assert len(files) == 1 and files[0].name.startswith("wendland-3d-artificial-")

    def no_bake(*a, **k):
        raise AssertionError("baked again although cached")

    monkeypatch.setattr(ww, "bake", no_bake)
    again = ww.bake_cached(*args, folder=tmp_path)
    assert np.array_equal(again.table, first.table) and again.support == first.support
    monkeypatch.undo()
    # another kernel, spacing or viscosity: another file
    other = ww.bake_cached("muller", 3, 0.02, 0.04, 1000.0, "artificial", folder=tmp_path)
    ww.bake_cached("wendland", 3, 0.02, 0.04, 1000.0, "laminar", folder=tmp_path)
    ww.bake_cached("wendland", 3, 0.01, 0.02, 1000.0, "artificial", folder=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 4
    assert not np.array_equal(other.table, first.table)
    # the key holds a hash of the sources that compute the curves: an edited kernel is baked again
    monkeypatch.setattr(ww, "_sources_hash", lambda: "edited")
    ww.bake_cached(*args, folder=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 5
    monkeypatch.undo()
    # and so does the set of curves: a cache written before the attraction row has another key
    key = ww.cache_key(*args)
    monkeypatch.setattr(ww, "ROWS", 7)
    assert ww.cache_key(*args) != key


def test_a_broken_or_unwritable_cache_is_ignored(tmp_path):
    args = ("wendland", 2, 0.01, 0.03, 1000.0, "artificial")
    key = ww.cache_key(*args)
    (tmp_path / f"{key}.npz").write_bytes(b"not an npz")
    curves = ww.bake_cached(*args, folder=tmp_path)
    assert np.array_equal(curves.table, ww.bake(*args).table)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert np.array_equal(ww.bake_cached(*args, folder=blocker / "sub").table, curves.table)
