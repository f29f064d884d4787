"""Interactive figures: self-contained HTML (plotly.js inside, nothing fetched), holding the right data: level curves
that are level curves, a map whose colours and hovers are the verdicts, a gait whose frames follow the path."""

from __future__ import annotations

import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest
from cli_helpers import run

import geomech as gm
from geomech.analysis import analyse_gait, stability_map
from geomech.integrators import ImplicitMidpoint
from geomech.plot.interactive import gait_html, momentum_sphere_html, stability_map_html
from geomech.systems.nonholonomic_examples import snakeboard_bkmm

ROTOR = ["--lambda", "3", "2", "--I3", "1", "--phi", "k*v"]


class _Resources(HTMLParser):
    """The external resources an HTML page loads: script, link and img sources."""

    def __init__(self) -> None:
        super().__init__()
        self.sources: list[str] = []
        self.scripts = 0

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.scripts += tag == "script"
        for key in ("src", "href"):
            if tag in ("script", "link", "img", "iframe") and attrs.get(key):
                self.sources.append(attrs[key])


def self_contained(path) -> str:
    text = path.read_text()
    page = _Resources()
    page.feed(text)
    assert page.scripts >= 1 and page.sources == []  # nothing to fetch
    assert len(text) > 1_000_000 and "Plotly.newPlot" in text  # plotly.js is inside
    return text


def test_momentum_sphere_draws_level_curves_of_H_and_the_trajectory(tmp_path):
    H = gm.LeftInvariantSystem.from_expression("m1**2/6 + m2**2/4 + m3**2/2")
    sol = gm.solve(H, ImplicitMidpoint(), m0=[0.1, 1.0, 0.2], t_final=10.0, h=0.05, backend="python")
    fig = momentum_sphere_html(sol.m, hamiltonian=H.hamiltonian, labels=["near m2"], path=tmp_path / "s.html")
    self_contained(tmp_path / "s.html")
    traces = {t.name: t for t in fig.data}
    G = np.linalg.norm(sol.m[0])
    x, y, z = (np.array(getattr(traces["level curves of H"], c), dtype=float) for c in "xyz")
    pts = np.stack([x, y, z], -1)
    breaks = np.nonzero(np.isnan(x))[0]
    assert len(breaks) >= 10
    np.testing.assert_allclose(np.linalg.norm(pts[~np.isnan(x)], axis=-1), G, rtol=1e-12)
    start = 0
    for end in breaks[:10]:  # along each curve H is one value (to the contouring's resolution)
        seg = pts[start:end]
        E = H.hamiltonian(seg)
        assert np.ptp(E) < 2e-3 * np.abs(E).max()
        start = end + 1
    np.testing.assert_allclose(np.array(traces["near m2"].x, dtype=float), sol.m[:, 0])


def test_stability_map_colours_and_hovers_are_the_verdicts(tmp_path):
    control = gm.StructurePreservingControl.one_rotor(
        gm.RotorBody.one_rotor(3.0, 2.0, 1.0), "k*v", parameters={"k": 0.5}, probe_radius=1.0
    )
    ds = stability_map(control.family(), ("k", np.linspace(0.05, 0.95, 4)), ("lambda2", np.linspace(1.2, 2.8, 3)))
    fig = stability_map_html(ds, path=tmp_path / "map.html")
    self_contained(tmp_path / "map.html")
    heat = fig.data[0]
    ticks = list(heat.colorbar.ticktext)
    codes = ds["verdict"].values
    meanings = ds["verdict"].attrs["flag_meanings"].split()
    values = [int(v) for v in ds["verdict"].attrs["flag_values"]]
    z = np.array(heat.z, dtype=float)
    for j in range(codes.shape[0]):
        for i in range(codes.shape[1]):
            name = meanings[values.index(int(codes[j, i]))]
            assert ticks[int(z[j, i])] == name.replace("_", " ")
            assert f"verdict: {name}" in heat.text[j][i]
    assert len(set(codes.ravel())) >= 2  # the grid crosses the boundary


def test_gait_frames_follow_the_path_at_equal_aspect(tmp_path):
    board = snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)
    a = analyse_gait(board, {"psi": "sin(4*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}, period=1.0, periods=2, p0=[0.2])
    fig = gait_html(a, frames=30, path=tmp_path / "gait.html")
    self_contained(tmp_path / "gait.html")
    assert len(fig.frames) == 30 and fig.layout.yaxis.scaleanchor == "x"
    g = a.path.g
    for frame in fig.frames[::7]:
        t = float(frame.name)
        k = int(np.argmin(np.abs(a.t - t)))
        body = frame.data[0]
        assert body.x[0] == pytest.approx(g[k, 0]) and body.y[0] == pytest.approx(g[k, 1])
        heading = np.arctan2(body.y[1] - body.y[0], body.x[1] - body.x[0])
        assert np.cos(heading - g[k, 2]) == pytest.approx(1.0)


def test_the_command_line_writes_the_figure_and_refuses_bad_paths(capsys, tmp_path):
    target = tmp_path / "map.html"
    grid = ["--x", "k=0.05:0.95:2", "--y", "lambda2=1.2:2.8:2", "--out", str(tmp_path / "o")]
    code, out, err = run(capsys, "stability-map", *ROTOR, *grid, "--html", str(target), "--json")
    assert code == 0, err
    assert str(target) in json.loads(out)["files"]
    self_contained(target)
    for bad in (str(tmp_path / "missing" / "m.html"), str(tmp_path / "m.png")):
        code, out, err = run(capsys, "stability-map", *ROTOR, *grid, "--html", bad)
        assert code == 2 and len(err.strip().splitlines()) == 1 and re.search("html|directory", err), err


def test_rigid_body_and_gait_commands_write_their_figures(capsys, tmp_path):
    target = tmp_path / "sphere.html"
    code, out, err = run(
        capsys, "rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--t-final", "5",
        "--html", str(target), "--json",
    )  # fmt: skip
    assert code == 0, err
    assert json.loads(out)["files"] == [str(target)]
    self_contained(target)
    gait = [
        "gait", "snakeboard_bkmm", "--param", "m=1", "--param", "r=1", "--param", "J0=0.3", "--param", "J1=0.1",
        "--period", "1", "--shape-loop", "psi=sin(4*pi*t/T)", "--shape-loop", "phi=0.4*sin(2*pi*t/T)",
    ]  # fmt: skip
    code, out, err = run(capsys, *gait, "--html", str(tmp_path / "gait.html"))
    assert code == 0, err
    self_contained(tmp_path / "gait.html")
    code, out, err = run(capsys, *gait, "--sweep", "m=1:2:2", "--out", str(tmp_path / "s"), "--html", "g.html")
    assert code == 2 and "--html" in err and len(err.strip().splitlines()) == 1


def test_phase_rigid_body_writes_the_momentum_curve(capsys, tmp_path):
    target = tmp_path / "phase.html"
    code, out, err = run(
        capsys, "phase", "rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2",
        "--html", str(target), "--json",
    )  # fmt: skip
    assert code == 0, err
    self_contained(target)
    assert "solid angle" in target.read_text()


def test_simulate_draws_the_planar_motion_and_the_momentum_sphere(capsys, tmp_path):
    board = tmp_path / "board.html"
    code, out, err = run(
        capsys, "simulate", "snakeboard", "--param", "m=1", "--param", "r=0.5", "--param", "J=0.18",
        "--param", "J0=0.05", "--param", "J1=0.01", "--shape", "psi=sin(2*pi*t)", "--shape", "phi=0.5*sin(2*pi*t)",
        "--t-final", "1", "--samples", "41", "--html", str(board), "--json",
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads(out)
    assert doc["files"] == [str(board)]
    self_contained(board)
    # the animation ends where the summary says the board ends
    html = board.read_text()
    final = doc["summary"]["final_configuration"]
    xs = [float(v) for v in re.findall(r'"x":\[([-0-9.e]+),', html)]
    assert any(abs(x - final["x"]) < 1e-9 * max(1.0, abs(final["x"])) + 1e-12 for x in xs)

    sphere = tmp_path / "sphere.html"
    code, out, err = run(
        capsys, "simulate", "--hamiltonian", "m1**2/6 + m2**2/4 + m3**2/2", "--momentum", "1", "0.3", "0.2",
        "--t-final", "5", "--html", str(sphere),
    )  # fmt: skip
    assert code == 0, err
    self_contained(sphere)
    assert str(sphere) in out


def test_simulate_refuses_html_for_a_motion_off_the_plane(capsys, tmp_path):
    model = tmp_path / "cart.py"
    model.write_text(
        "from geomech.lie import Rn\n"
        "from geomech.systems.nonholonomic import NonholonomicSystem\n"
        "system = NonholonomicSystem.from_lagrangian('(x_dot**2 + y_dot**2 + r_dot**2)/2', Rn('x', 'y'), ['r'],\n"
        "    ['x_dot - cos(r)*y_dot'], name='cart')\n"
    )
    target = tmp_path / "cart.html"
    code, out, err = run(capsys, "simulate", str(model), "--shape", "r=sin(t)", "--html", str(target))
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "--html" in err and "plane" in err and not target.exists()


def test_reproduce_draws_every_approach_on_the_sphere(capsys, tmp_path):
    target = tmp_path / "study.html"
    code, out, err = run(
        capsys, "reproduce", "serret-andoyer", "--t-final", "0.5", "--no-extras", "--out", str(tmp_path / "o"),
        "--html", str(target), "--json",
    )  # fmt: skip
    assert code == 0, err
    assert json.loads(out)["files"] == [str(target)]
    self_contained(target)
    html = target.read_text()
    for label in ("Adams", "midpoint"):  # the approaches' names are the traces' names
        assert label.lower() in html.lower()
    code, out, err = run(
        capsys, "reproduce", "serret-andoyer", "--out", str(tmp_path / "s"), "--sweep", "h=0.001:0.002:2",
        "--html", str(tmp_path / "x.html"),
    )  # fmt: skip
    assert code == 2 and "--html" in err and "--sweep" in err


@pytest.mark.parametrize(
    "model, loop, planar",
    [
        ("three_link_middle", ["alpha1=0.6*cos(2*pi*t/T)", "alpha2=0.6*sin(2*pi*t/T)"], True),
        ("two_bodies", ["psi=2*pi*t/T"], False),
    ],
)
def test_phase_loop_draws_the_reconstructed_motion(capsys, tmp_path, model, loop, planar):
    from geomech.analysis import Gait, reconstruct
    from geomech.plot.interactive import reconstruction_html
    from geomech.systems.models import example_system

    target = tmp_path / "loop.html"
    shapes = [a for s in loop for a in ("--shape", s)]
    code, out, err = run(capsys, "phase", "loop", model, *shapes, "--html", str(target), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["files"] == [str(target)]
    self_contained(target)
    # the figure holds the reconstruction: animated in the plane, or the coordinates against time
    system = example_system(model, {})
    rec = reconstruct(system, Gait.from_expressions(dict(s.split("=", 1) for s in loop), 1.0))
    fig = reconstruction_html(system, rec)
    if planar:
        assert len(fig.frames) > 10 and fig.layout.yaxis.scaleanchor == "x"
        body = fig.frames[-1].data[0]
        assert body.x[0] == pytest.approx(rec.path.g[-1, 0]) and body.y[0] == pytest.approx(rec.path.g[-1, 1])
    else:
        assert not fig.frames
        theta = np.asarray(fig.data[0].y, dtype=float)
        assert theta[-1] - theta[0] == pytest.approx(doc["summary"]["net_displacement"]["theta"], abs=1e-9)


def test_two_bodies_and_show_write_their_figures(capsys, tmp_path):
    from geomech.plot.interactive import series_html

    target = tmp_path / "bodies.html"
    args = ["phase", "two-bodies", "--I1", "1", "--I2", "3", "--mu", "-2.5", "--period", "5.5", "--turns", "-1"]
    code, out, err = run(capsys, *args, "--html", str(target), "--json")
    assert code == 0, err
    assert json.loads(out)["files"] == [str(target)]
    self_contained(target)

    code, out, err = run(
        capsys, "simulate", "--hamiltonian", "m1**2/6 + m2**2/4 + m3**2/2", "--momentum", "1", "0.3", "0.2",
        "--t-final", "2", "--out", str(tmp_path / "run"),
    )  # fmt: skip
    assert code == 0, err
    shown = tmp_path / "show.html"
    code, out, err = run(capsys, "show", str(tmp_path / "run" / "trajectory.nc"), "--html", str(shown), "--json")
    assert code == 0, err
    assert json.loads(out)["files"] == [str(shown)]
    self_contained(shown)
    # the traces are the variables' components, over the file's times
    t = np.linspace(0.0, 1.0, 5)
    fig = series_html(t, {"m": np.stack([t, 2 * t, 3 * t], -1), "energy": t**2})
    assert [tr.name for tr in fig.data] == ["m[0]", "m[1]", "m[2]", "energy"]
    np.testing.assert_array_equal(np.asarray(fig.data[2].y, dtype=float), 3 * t)
