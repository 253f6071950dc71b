"""The command line answers in seconds (issue 38), checked on what makes it slow, never on time:

- building the parser (``clamp --version``, ``--help``, a usage error) and ``import clamp``
  load none of the heavy libraries (GTSAM, SciPy, Pinocchio, matplotlib, rosbags, viser, Dask,
  TOPP-RA), and the public names still resolve;
- ``clamp --version`` answers before NumPy loads; retiming loads TOPP-RA without matplotlib;
- a second ``clamp plan`` on the same URDF arm reads the collision spheres the first one fitted
  (a cache entry shared by processes) and plans the very same q; no figures unless asked for,
  and no warning about ``clamp view`` (the package folders are recorded for it).

Run as a user would: ``python -m clamp`` in a subprocess.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from robots.sphere_cache import CACHE_ENV

ROOT = Path(__file__).resolve().parents[3]
HEAVY = ("gtsam", "scipy", "pinocchio", "matplotlib", "rosbags", "viser", "dask", "toppra", "coal")


def python(args: list[str], cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ if env is None else env, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=900)


def loaded_after(code: str, tmp_path: Path) -> list[str]:
    """The heavy libraries loaded once ``code`` has run in a fresh interpreter."""
    done = python(["-c", f"import sys\n{code}\nprint(sorted({{m.split('.')[0] for m in sys.modules}} & "
                         f"set({HEAVY!r})))"], tmp_path)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1].replace("'", '"'))


def test_the_parser_loads_no_heavy_library(tmp_path):
    code = ("from clamp.cli.commands import parser\n"
            "try:\n    parser().parse_args(['--version'])\nexcept SystemExit:\n    pass")
    assert loaded_after(code, tmp_path) == []
    done = python(["-m", "clamp", "--version"], tmp_path)
    assert done.returncode == 0 and done.stdout.startswith("clamp ")


def test_importing_the_packages_loads_no_heavy_library_and_names_resolve(tmp_path):
    assert loaded_after("import clamp, robots, scenes", tmp_path) == []
    code = ("import clamp, robots, scenes\n"
            "assert callable(clamp.plan) and callable(clamp.learn_prior) and callable(robots.retime)\n"
            "assert scenes.Box.__name__ == 'Box' and set(clamp.__all__) <= set(dir(clamp))")
    assert "gtsam" in loaded_after(code, tmp_path)              # loaded when a name is used


def test_a_second_plan_reads_the_fitted_spheres_and_plans_the_same_q(tmp_path, prior):
    from robots.registry import example_robot_data_share
    from scenes import Box, Scene
    share = example_robot_data_share()
    urdf = share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf"
    prior.save(tmp_path / "prior.npz")
    mean = prior.mean[:, :3]
    Scene([Box(mean[len(mean) // 2], [0.03, 0.03, 0.03])]).save(tmp_path / "scene.json")
    env = dict(os.environ, **{CACHE_ENV: str(tmp_path / "cache")})    # a fresh, empty cache
    runs = []
    for name in ("cold", "warm"):
        done = python(["-m", "clamp", "plan", "-v", "--urdf", str(urdf), "--end-effector", "panda_hand",
                       "--package-dir", str(share), "--prior", "prior.npz", "--scene", "scene.json",
                       "--start", *map(str, mean[0]), "--out", name], tmp_path, env)
        assert done.returncode == 0, done.stderr
        assert "clamp view" not in done.stderr and "WARNING" not in done.stderr, done.stderr
        runs.append(done)
        entries = sorted((tmp_path / "cache" / "spheres").glob("*.json"))
        assert len(entries) == 1
        if name == "cold":
            stored = entries[0].read_bytes()
    assert entries[0].read_bytes() == stored                        # read, not written again
    assert "fitted and cached" in runs[0].stderr and "read from the cache" in runs[1].stderr
    cold, warm = (json.loads((tmp_path / name / "plan.json").read_text()) for name in ("cold", "warm"))
    assert cold["success"] and np.array_equal(np.array(cold["q"]), np.array(warm["q"]))
    for name in ("cold", "warm"):                                   # figures only with --figures
        assert not list((tmp_path / name).glob("*.png")) and not list((tmp_path / name).glob("*.html"))
    problem = json.loads((tmp_path / "warm" / "problem_plan.json").read_text())
    assert problem["robot"]["package_dirs"] == [str(share.resolve())]


def test_clamp_show_draws_the_figures_of_a_saved_plan(tmp_path, capsys, monkeypatch):
    from clamp.cli.commands import main
    from scenes import Box, Scene, make_demonstrations
    demos = make_demonstrations("box_closing", num_points=40, seed=1)
    demos.save_npz(tmp_path / "demos.npz")
    Scene([Box([0.9, 0.9, 0.5], [0.05, 0.05, 0.05])]).save(tmp_path / "scene.json")
    out = tmp_path / "out"
    assert main(["plan", "-q", "--demos", str(tmp_path / "demos.npz"), "--robot", "jaco", "--start",
                 *map(str, demos.positions[:, 0].mean(axis=0)), "--scene", str(tmp_path / "scene.json"),
                 "--out", str(out)]) == 0
    assert not list(out.glob("*.png"))
    assert main(["show", str(out)]) == 0
    for name in ("prior_3d.png", "plan_result.png", "plan_result_top.png", "plan_result_joints.png",
                 "plan_result_clearance.png", "animation_result.html"):
        assert (out / name).stat().st_size > 0, name
    assert "wrote the figures and the animation of plan 'plan'" in capsys.readouterr().out
    assert main(["show", str(out)]) == 2                            # drawn already: only with --force
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "--force" in line and "plan_result.png" in line
    import clamp.cli.figures as figures
    drawn = {}
    monkeypatch.setattr(figures, "write_figures", lambda *args: drawn.update(args[-1]))
    recorded = json.loads((out / "plan.json").read_text())["trajectory"]["state_times"]
    assert main(["show", str(out), "--force"]) == 0                  # on the trajectory's clock
    assert list(drawn) == ["result"] and np.array_equal(drawn["result"], recorded)
    drawn.clear()
    assert main(["show", str(out), "--force", "--clock", "skill"]) == 0 and drawn == {}


def test_retiming_loads_toppra_without_matplotlib_and_its_plotting_still_reaches_pyplot(tmp_path):
    retimed = ("from robots import JointTrajectory, load_robot, retime\nimport numpy as np\n"
               "robot = load_robot('jaco')\nt = np.linspace(0.0, 2.0, 30)\n"
               "q = np.linspace(robot.neutral_configuration(), robot.neutral_configuration() + 0.5, 30)\n"
               "traj = JointTrajectory.from_plan(robot, t, q, np.gradient(q, t, axis=0))\n"
               "out, report = retime(traj, robot, 2.0, method='toppra')\n"
               "assert report.method == 'toppra' and out.duration > 0")
    loaded = loaded_after(retimed, tmp_path)
    assert "toppra" in loaded and "matplotlib" not in loaded
    plotting = ("from robots.retiming import import_toppra\nimport_toppra()\n"
                "import toppra.algorithm.algorithm as algorithm, matplotlib.pyplot as plt\n"
                "assert algorithm.plt.plot is plt.plot")
    assert "matplotlib" in loaded_after(plotting, tmp_path)


def test_version_answers_before_numpy_loads_as_the_parser_does(tmp_path):
    code = ("import sys\nfrom clamp.cli import main\nassert main(['--version']) == 0\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'numpy', 'gtsam', 'scipy'}))")
    done = python(["-c", code], tmp_path)
    assert done.returncode == 0, done.stderr
    fast, loaded = done.stdout.strip().splitlines()
    assert loaded == "[]"
    parsed = python(["-c", "from clamp.cli.commands import parser\nparser().parse_args(['--version'])"], tmp_path)
    assert parsed.returncode == 0 and parsed.stdout.strip() == fast and fast.startswith("clamp ")
    entry = python(["-c", "import clamp.cli\nassert clamp.cli.main(['demo', '--skill', 'x']) == 2\n"
                          "assert callable(clamp.cli.main)"], tmp_path)    # still the entry point
    assert entry.returncode == 0, entry.stderr
