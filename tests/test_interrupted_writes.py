"""Every writer of an output interrupted half-way: the old file or none is
left, never a partial one."""
import numpy as np
import pytest


class Cut(KeyboardInterrupt):
    """Ctrl-C arriving half-way through a write."""


def _cut_after_half(write):
    """``write(target, data)`` (a path's ``write_text``) that writes half of
    what it is given and is then interrupted."""
    def half(self, data, *a, **k):
        write(self, data[:max(1, len(data) // 2)], *a, **k)
        raise Cut
    return half


def _cut_producer(produce):
    """``produce(obj, target, ...)`` (``io.write_npz``, ``Figure.savefig``) that
    writes half of its bytes to ``target`` (a path or a binary file) and
    is then interrupted."""
    def half(*a, **k):
        import io as _io

        buf = _io.BytesIO()
        a = list(a)
        target_at = 1 if hasattr(a[0], "savefig") else 0
        target, a[target_at] = a[target_at], buf
        produce(*a, **k)
        data = buf.getvalue()[:len(buf.getvalue()) // 2]
        if hasattr(target, "write"):
            target.write(data)
            target.flush()
        else:
            with open(target, "wb") as fh:
                fh.write(data)
        raise Cut
    return half


def _writers(tmp_path):
    """(kind, path, write(path), (owner, name) of the function to cut) of
    every kind of writer: text, JSON, binary (a plan's .npz), a figure."""
    from pathlib import Path

    from matplotlib.figure import Figure

    from bplir_drake import io
    from bplir_drake.planning import cache as plan_cache
    from bplir_drake.planning.cache import _write_npz
    from bplir_drake.plotting import save_figure

    def figure():
        fig = Figure()
        fig.add_subplot().plot([0, 1], [0, 1])
        return fig

    return {
        "text": (tmp_path / "a.md", lambda p: io.write_text_atomic(p, "new text " * 5000),
                 (Path, "write_text", _cut_after_half)),
        "json": (tmp_path / "a.json", lambda p: io.write_json_atomic(p, {"x": list(range(5000))}),
                 (Path, "write_text", _cut_after_half)),
        "binary": (tmp_path / "a.npz", lambda p: _write_npz(p, {"x": np.arange(50000.0)}),
                   (plan_cache, "write_npz", _cut_producer)),
        "figure": (tmp_path / "a.png", lambda p: save_figure(figure(), p),
                   (Figure, "savefig", _cut_producer)),
    }


@pytest.mark.parametrize("kind", ["text", "json", "binary", "figure"])
def test_an_interrupted_writer_leaves_the_old_file_whole(kind, tmp_path, monkeypatch):
    """Every output goes through the atomic writer: a write interrupted
    half-way (Ctrl-C) leaves the old file as it was and no temporary file
    beside it.  A writer that wrote in place would leave half a file here
    (``io.write_text_atomic`` replaced by a plain write fails this test)."""
    path, write, (owner, name, cut) = _writers(tmp_path)[kind]
    old = b"the finished run's file\n"
    path.write_bytes(old)
    monkeypatch.setattr(owner, name, cut(getattr(owner, name)))
    with pytest.raises(Cut):
        write(path)
    monkeypatch.undo()
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


class _HalfFile:
    """A text file whose next write is cut half-way by an interruption."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, text):
        self.fh.write(text[:len(text) // 2])
        self.fh.flush()
        raise Cut


def test_an_interrupted_row_is_dropped_and_the_finished_rows_kept(tmp_path):
    """A study's results table: a row cut half-way by an interruption is
    left out when the study is read back (and rewritten) on resume; the
    rows finished before it are kept."""
    import csv

    from bplir_drake.analysis.montecarlo.store import ResultWriter, read_results

    cols = ["index", "seed", "outcome", "error"]
    path = tmp_path / "results.csv"
    writer = ResultWriter(path, cols, [])
    writer.write({"index": 0, "seed": 7, "outcome": "captured", "error": ""})
    writer._w = csv.writer(_HalfFile(writer._fh))
    with pytest.raises(Cut):
        writer.write({"index": 1, "seed": 8, "outcome": "captured", "error": ""})
    writer.close()
    assert path.read_text().count("\n") == 2 and not path.read_text().endswith("\n")
    rows = read_results(path, cols)
    assert [r["index"] for r in rows] == [0]
    ResultWriter(path, cols, rows).close()   # the resumed study rewrites the whole rows
    assert path.read_text() == "index,seed,outcome,error\n0,7,captured,\n"


