"""The tlgc command line: fit-reproduce writes the cylinder, reproductions and figures."""
from __future__ import annotations

import numpy as np

from scenes import make_demonstrations
from tlgc import GeneralizedCylinder
from tlgc.cli import main


def test_fit_reproduce_from_a_file_writes_outputs(tmp_path, capsys):
    demos = make_demonstrations("pick_place", num_demos=4, num_points=200, seed=0)
    path = tmp_path / "demos.npz"
    demos.save_npz(path)
    out = tmp_path / "out"
    status = main(["fit-reproduce", "--demos", str(path), "--cross-section", "ellipse",
                   "--out", str(out), "--count", "7", "--eta-final", "0", "--sections", "3"])
    assert status == 0
    for name in ("cylinder.npz", "reproductions.npy", "cylinder.png", "cross_sections.png"):
        assert (out / name).stat().st_size > 0
    cyl = GeneralizedCylinder.load(out / "cylinder.npz")
    reps = np.load(out / "reproductions.npy")
    assert cyl.cross_section == "ellipse" and reps.shape == (7, 200, 3)
    np.testing.assert_allclose(reps[:, -1], np.broadcast_to(cyl.directrix[-1], (7, 3)), atol=1e-3)
    assert "points inside 100.00 %" in capsys.readouterr().out


def test_fit_reproduce_real_data(tmp_path, capsys, shared_dataset):
    path = shared_dataset("needle_threading")
    assert main(["fit-reproduce", "--demos", str(path), "--out", str(tmp_path), "--count", "5"]) == 0
    assert "N=1500" in capsys.readouterr().out


def test_bad_input_gives_one_error_line(tmp_path, capsys):
    status = main(["fit-reproduce", "--skill", "curved_reach", "--out", str(tmp_path),
                   "--eta-final", "2"])
    assert status == 2
    assert "eta_final" in capsys.readouterr().err
    assert main(["fit-reproduce", "--skill", "curved_reach", "--out", str(tmp_path),
                 "--cross-section", "square"]) == 2
    assert "square" in capsys.readouterr().err
    assert main(["fit-reproduce", "--demos", str(tmp_path / "missing.mat"), "--out", str(tmp_path)]) == 2
    assert "missing.mat" in capsys.readouterr().err
