"""Linking blobs into tracklets: identities kept through near passes and short gaps."""

from trackers.blob import Blob, BlobParams
from trackers.movers import MoverLinker


def _blob(x, y, area=300.0, polarity=-1):
    return Blob(x, y, area, 12.0, 30.0, polarity, 30.0)


def _run(frames):
    linker = MoverLinker(BlobParams())
    out = []
    for k, blobs in enumerate(frames):
        out += [(k, tid, b.x, b.y) for tid, b, _ in linker.step(k, blobs)]
    return out


def test_two_walkers_passing_close_keep_their_ids():
    # A walks right along y=100, B walks left along y=112: they pass 12 px apart at frame 20.
    frames = [[_blob(10 + 5 * k, 100), _blob(210 - 5 * k, 112)] for k in range(41)]
    rows = _run(frames)
    by_id = {}
    for k, tid, x, y in rows:  # noqa: B007 (the rows' layout, named)
        by_id.setdefault(tid, []).append(y)
    assert len(by_id) == 2
    assert sorted(set(ys[0] for ys in by_id.values())) == [100, 112]
    for ys in by_id.values():
        assert len(set(ys)) == 1  # each tracklet stays on one walker


def test_short_gap_keeps_the_id_long_gap_starts_a_new_one():
    path = [_blob(10 + 4 * k, 50) for k in range(30)]
    short = [[b] if not 10 <= k < 13 else [] for k, b in enumerate(path)]
    assert len({tid for _, tid, _, _ in _run(short)}) == 1
    long = [[b] if not 10 <= k < 20 else [] for k, b in enumerate(path)]
    assert len({tid for _, tid, _, _ in _run(long)}) == 2


def test_other_polarity_or_size_is_not_linked():
    frames = [[_blob(50 + k, 50)] for k in range(5)] + [[_blob(55, 50, polarity=1)]] + [[_blob(56, 50, area=3000.0)]]
    ids = [tid for _, tid, _, _ in _run(frames)]
    assert ids[:5] == [ids[0]] * 5
    assert len(set(ids)) == 3
