"""Bad input gets a clear answer and loses nothing.

Every malformed input below goes through the command line (``signatelec.cli.main`` in-process,
two through a subprocess) and must give:

- exit code 2;
- exactly one line on stderr, ``signatelec: error: ...``, naming the input (the scene file or the
  command-line option), the field and what is allowed; no traceback;
- nothing left behind: the ``--out`` directory does not exist afterwards and its parent holds
  exactly what it held before (no temporary files).

None of these inputs reaches the time loop, so no kernel is compiled or run.

Dataset specs and traces join this matrix when the ``dataset`` and ``trace`` commands exist.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from signatelec.cli import main


@dataclass(frozen=True)
class Case:
    """A malformed input: scene file text (or bytes), extra arguments, expected fragments."""

    scene: str | bytes | None
    args: tuple[str, ...]
    expected: tuple[str, ...]  # the field and what is allowed, as they appear in the message


#: A TOML integer of 400 digits: far beyond the float range (~1.8e308).
HUGE = "1" + "0" * 399

SCENE_CASES = {
    # structure
    "unknown_key": Case(
        "[operating]\nradial_load = 5820.0\n",
        (),
        ("operating.radial_load", "unknown key; allowed: radial_load_n"),
    ),
    "unknown_section": Case(
        "[operation]\nradial_load_n = 5820.0\n",
        (),
        ("operation", "unknown section; allowed: bearing, operating"),
    ),
    "section_not_a_table": Case('effects = "all"\n', (), ("effects = 'all'", "must be a table")),
    # defects and abnormal loads
    "defect_location": Case(
        '[[defects]]\nlocation = "cage"\nlength_m = 1e-3\ndepth_m = 1e-5\n',
        (),
        ("defects[0].location = 'cage'", "must be one of outer, inner, ball"),
    ),
    "defect_too_deep": Case(
        '[[defects]]\nlocation = "outer"\nlength_m = 1e-3\ndepth_m = 1e-3\n',
        (),
        ("defects[0].depth_m = 0.001", "must be <= 0.00063 m (10 % of the ball radius)"),
    ),
    "defect_longer_than_its_ball": Case(
        '[[defects]]\nlocation = "ball"\nlength_m = 0.05\ndepth_m = 1e-5\n',
        (),
        ("defects[0].length_m = 0.05", "shorter than the circumference of the ball"),
    ),
    "defect_on_a_ball_that_is_not_there": Case(
        '[[defects]]\nlocation = "ball"\nball = 13\nlength_m = 1e-3\ndepth_m = 1e-5\n',
        (),
        ("defects[0].ball = 13", "must be a ball in [0, 12]"),
    ),
    "defects_not_an_array": Case(
        '[defects]\nlocation = "outer"\n', (), ("defects = ", "must be an array of tables")
    ),
    "load_table_times_decrease": Case(
        "[loads]\nload_table_time_s = [0.02, 0.01]\nload_table_radial_load_n = [1.0, 2.0]\n",
        (),
        ("loads.load_table_time_s[1] = 0.01", "times must increase"),
    ),
    "load_table_lengths_differ": Case(
        "[loads]\nload_table_time_s = [0.02]\nload_table_radial_load_n = [1.0, 2.0]\n",
        (),
        ("loads.load_table_radial_load_n", "as many points as load_table_time_s (1)"),
    ),
    "unbalance_beyond_the_load_limit": Case(
        "[loads]\nunbalance_force_n = 1e6\n", (), ("loads.unbalance_force_n", "the largest F_r")
    ),
    "unbalance_in_both_forms": Case(
        "[loads]\nunbalance_force_n = 10.0\nunbalance_mass_kg = 0.01\n"
        "unbalance_eccentricity_m = 1e-3\n",
        (),
        ("loads.unbalance_force_n = 10.0", "not both"),
    ),
    "lobes_not_an_integer": Case(
        "[housing]\nout_of_round_lobes = 2.5\n", (), ("housing.out_of_round_lobes", "integer")
    ),
    "lobes_missing": Case(
        "[housing]\nout_of_round_amplitude_m = 1e-6\n",
        (),
        ("housing.out_of_round_amplitude_m", "needs out_of_round_lobes >= 1"),
    ),
    # types
    "string_for_number": Case(
        '[operating]\nradial_load_n = "5820"\n', (), ("operating.radial_load_n", "must be a number")
    ),
    "integer_for_bool": Case(
        "[outputs]\nenergy = 1\n", (), ("outputs.energy", "must be true or false")
    ),
    "integer_for_model": Case(
        "[effects]\ncage = 1\n",
        (),
        ("effects.cage", "must be one of balls, rigid, none (true: balls, false: none)"),
    ),
    "unknown_model": Case(
        "[effects]\nfriction = 'viscous'\n",
        (),
        ("effects.friction", "must be one of coulomb, none (true: coulomb, false: none)"),
    ),
    "key_of_the_earlier_layout": Case(
        "[effects]\nelectrical = false\n",
        (),
        ("effects.electrical", "unknown key", "[outputs] holds it now"),
    ),
    "array_for_number": Case(
        "[operating]\nomega_rad_s = [500.0, 600.0]\n", (), ("operating.omega_rad_s", "a number")
    ),
    "bool_for_friction": Case(
        "[bearing]\nfriction_coefficient = true\n",
        (),
        ("bearing.friction_coefficient", "must be a finite number in [0, 2]"),
    ),
    "number_for_name": Case("[bearing]\nname = 6208\n", (), ("bearing.name", "must be a string")),
    # non-finite
    "nan": Case(
        "[operating]\nradial_load_n = nan\n", (), ("operating.radial_load_n", "finite number")
    ),
    "inf": Case("[operating]\nomega_rad_s = inf\n", (), ("operating.omega_rad_s", "finite number")),
    "nan_material": Case(
        "[bearing.cage_material]\nname = 'x'\nyoungs_modulus_pa = nan\npoisson = 0.3\n"
        "density_kg_m3 = 1140.0\n",
        (),
        ("bearing.cage_material.youngs_modulus_pa", "must be a finite number in"),
    ),
    # geometry
    "negative_radius": Case(
        "[bearing]\nball_radius_m = -6.3e-3\n", (), ("bearing.ball_radius_m", "finite number > 0")
    ),
    "zero_radius": Case(
        "[bearing]\ncage_ball_radius_m = 0.0\n",
        (),
        ("bearing.cage_ball_radius_m", "finite number > 0"),
    ),
    "balls_do_not_fit": Case(
        "[bearing]\nn_balls = 40\n", (), ("bearing.n_balls = 40", "do not fit on the pitch circle")
    ),
    "fractional_ball_count": Case(
        "[bearing]\nn_balls = 13.5\n", (), ("bearing.n_balls", "must be an integer >= 3")
    ),
    "outer_race_inconsistent": Case(
        "[bearing]\nouter_race_radius_m = 40e-3\n",
        (),
        ("bearing.outer_race_radius_m", "must equal inner_race_radius_m + 2 ball_radius_m"),
    ),
    "unknown_material": Case(
        "[bearing]\nball_material = 'unobtainium'\n",
        (),
        ("bearing.ball_material", "unknown material; allowed: steel, polyamide"),
    ),
    "material_unknown_key": Case(
        "[bearing.cage_material]\nname = 'x'\ncolour = 'black'\n",
        (),
        ("bearing.cage_material.colour", "unknown key; allowed: name, youngs_modulus_pa"),
    ),
    "material_missing_keys": Case(
        "[bearing.cage_material]\nname = 'x'\n",
        (),
        ("bearing.cage_material", "missing youngs_modulus_pa, poisson, density_kg_m3"),
    ),
    # operating point
    "preload_beyond_limit": Case(
        "[operating]\nclearance_m = -250e-6\n",
        (),
        ("operating.clearance_m", "4.2 GPa static contact pressure"),
    ),
    "clearance_beyond_5_percent": Case(
        "[operating]\nclearance_m = 1e-3\n", (), ("operating.clearance_m", "must be within")
    ),
    "absurd_radial_load": Case(
        "[operating]\nradial_load_n = 1e300\n",
        (),
        ("operating.radial_load_n", "must be <= ", "5 % of the ball radius"),
    ),
    "negative_current": Case(
        "[operating]\ninjected_current_a = -0.1\n",
        (),
        ("operating.injected_current_a", "must be > 0 A"),
    ),
    # effects and numerics
    "invalid_contact_law": Case(
        "[effects]\ncontact_law = 'hooke'\n",
        (),
        ("effects.contact_law", "must be one of hertz, harris, linear"),
    ),
    "invalid_integrator": Case(
        "[numerics]\nintegrator = 'rk4'\n", (), ("numerics.integrator", "one of verlet, euler")
    ),
    "dt_zero": Case("[numerics]\ndt_s = 0.0\n", (), ("numerics.dt_s", "must be > 0 s")),
    "dt_negative": Case("[numerics]\ndt_s = -1e-7\n", (), ("numerics.dt_s", "must be > 0 s")),
    "duration_shorter_than_setup": Case(
        "[numerics]\nduration_s = 0.005\n",
        (),
        ("numerics.duration_s", "must exceed the set-up phases"),
    ),
    "setup_longer_than_duration": Case(
        # the automatic duration follows the set-up; a duration given is checked against it
        "[procedure]\nspin_up_time_s = 0.05\n[numerics]\nduration_s = 0.03\n",
        (),
        ("numerics.duration_s", "must exceed the set-up phases"),
    ),
    "zero_sample_rate": Case(
        "[numerics]\nsample_rate_hz = 0.0\n", (), ("numerics.sample_rate_hz", "must be in (0,")
    ),
    "dt_above_stability_limit": Case(
        "[numerics]\ndt_s = 1e-5\n",
        (),
        ("numerics.dt_s", "above the stability limit", "use dt_s <="),
    ),
    # numbers checked before any conversion: a 400-digit integer, subnormal and tiny time steps
    "integer_of_400_digits": Case(
        f"[operating]\nradial_load_n = {HUGE}\n",
        (),
        ("operating.radial_load_n = 1000", "must be a finite number"),
    ),
    "duration_of_400_digits": Case(
        f"[numerics]\nduration_s = {HUGE}\n",
        (),
        ("numerics.duration_s = 1000", "must be a finite number"),
    ),
    "ball_count_of_400_digits": Case(
        f"[bearing]\nn_balls = {HUGE}\n",
        (),
        ("bearing.n_balls = 1000", "must be an integer >= 3 and <= 10000"),
    ),
    "radius_of_400_digits": Case(
        f"[bearing]\nball_radius_m = {HUGE}\n",
        (),
        ("bearing.ball_radius_m = 1000", "must be a finite number > 0"),
    ),
    "modulus_of_400_digits": Case(
        f"[bearing.cage_material]\nname = 'x'\nyoungs_modulus_pa = {HUGE}\npoisson = 0.3\n"
        "density_kg_m3 = 1140.0\n",
        (),
        ("bearing.cage_material.youngs_modulus_pa = 1000", "must be a finite number in [1e+06"),
    ),
    "dt_subnormal": Case(
        "[numerics]\ndt_s = 5e-324\n", (), ("numerics.dt_s = 5e-324", "must be >= 1e-12 s")
    ),
    "dt_tiny": Case(
        "[numerics]\ndt_s = 1e-300\n", (), ("numerics.dt_s = 1e-300", "must be >= 1e-12 s")
    ),
    "sample_rate_subnormal": Case(
        "[numerics]\nsample_rate_hz = 5e-324\n",
        (),
        ("numerics.sample_rate_hz = 5e-324", "must be >= 1/duration_s"),
    ),
    # what a run would cost, checked before it starts
    "too_many_steps": Case(
        "[numerics]\ndt_s = 1e-12\n",
        (),
        ("numerics.dt_s = 1e-12", "3e+10 steps, more than the 1e+09", "raise numerics.dt_s"),
    ),
    "too_many_instants": Case(
        "[numerics]\nsample_rate_hz = 1e7\nduration_s = 100.0\n",
        (),
        ("numerics.sample_rate_hz", "more than the 1e+08 a run may record"),
    ),
    "no_instant_after_the_set_up": Case(
        "[numerics]\nsample_rate_hz = 148.0\nduration_s = 0.0075\n",
        (),
        ("numerics.sample_rate_hz = 148.0", "records no instant after the set-up"),
    ),
    "no_allowed_time_step": Case(
        "[effects]\ncontact_law = 'linear'\n[numerics]\nlinear_stiffness_n_m = 1e300\n",
        (),
        ("numerics.dt_s", "no allowed time step runs this scene", "below the smallest dt_s"),
    ),
    # files
    "not_toml": Case("this is not = = TOML [\n", (), ("not valid TOML",)),
    "binary_garbage": Case(bytes(range(256)) * 8, (), ("is not UTF-8 text", "TOML file")),
}

OPTION_CASES = {
    "dt_negative": Case(None, ("--dt", "-1"), ("--dt -1.0", "numerics.dt_s", "must be > 0 s")),
    "radial_load_nan": Case(
        None, ("--radial-load", "nan"), ("--radial-load nan", "must be a finite number")
    ),
    "omega_text": Case(None, ("--omega", "text"), ("'--omega'", "'text' is not a valid float")),
    "omega_negative": Case(None, ("--omega", "-5"), ("--omega -5.0", "must be >= 0 rad/s")),
    "duration_too_short": Case(
        None, ("--duration", "0.001"), ("--duration 0.001", "must exceed the set-up phases")
    ),
    "clearance_too_large": Case(
        None, ("--clearance", "1"), ("--clearance 1.0", "operating.clearance_m", "must be within")
    ),
    "dt_above_stability_limit": Case(
        None, ("--dt", "1e-5"), ("--dt 1e-05", "above the stability limit", "use dt_s <=")
    ),
    "dt_subnormal": Case(
        None, ("--dt", "5e-324"), ("--dt 5e-324", "numerics.dt_s", "must be >= 1e-12 s")
    ),
    "dt_too_many_steps": Case(
        None, ("--dt", "1e-12"), ("--dt 1e-12", "numerics.dt_s", "steps, more than the 1e+09")
    ),
    "unknown_option": Case(None, ("--load", "5820"), ("No such option", "--load", "--radial-load")),
}


@pytest.fixture
def workspace(tmp_path):
    """(scene directory, output parent) kept apart so the output parent's content is known."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    return scenes, work


def run_main(argv, capsys) -> tuple[int, list[str]]:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    captured = capsys.readouterr()
    return exc.value.code, captured.err.splitlines()


def assert_one_clear_line(code, err, expected):
    assert code == 2, err
    assert len(err) == 1, err
    line = err[0]
    assert line.startswith("signatelec: error: ") and "Traceback" not in line
    for fragment in expected:
        assert fragment in line, (fragment, line)


def assert_nothing_left(work: Path, out: Path, before: set[str]):
    assert not out.exists()
    assert {p.name for p in work.iterdir()} == before


@pytest.mark.parametrize("name", sorted(SCENE_CASES))
def test_bad_scene_file(name, workspace, capsys):
    case = SCENE_CASES[name]
    scenes, work = workspace
    scene = scenes / f"{name}.toml"
    if isinstance(case.scene, bytes):
        scene.write_bytes(case.scene)
    else:
        scene.write_text(case.scene)
    out = work / "out"
    argv = ["simulate", "--scene", str(scene), *case.args, "--out", str(out), "--quiet"]
    code, err = run_main(argv, capsys)
    assert_one_clear_line(code, err, (repr(str(scene)), *case.expected))
    assert_nothing_left(work, out, set())


@pytest.mark.parametrize("name", sorted(OPTION_CASES))
def test_bad_option(name, workspace, capsys):
    case = OPTION_CASES[name]
    _, work = workspace
    out = work / "out"
    code, err = run_main(["simulate", *case.args, "--out", str(out), "--quiet"], capsys)
    assert_one_clear_line(code, err, case.expected)
    assert_nothing_left(work, out, set())


def test_option_conflicting_with_the_scene_names_both(workspace, capsys):
    scenes, work = workspace
    scene = scenes / "long_spin_up.toml"
    scene.write_text("[procedure]\nspin_up_time_s = 0.02\n")
    out = work / "out"
    argv = ["simulate", "--scene", str(scene), "--duration", "0.01", "--out", str(out)]
    code, err = run_main(argv, capsys)
    expected = (repr(str(scene)), "--duration 0.01", "numerics.duration_s", "must exceed")
    assert_one_clear_line(code, err, expected)
    assert_nothing_left(work, out, set())


def test_missing_scene_file(workspace, capsys):
    scenes, work = workspace
    out = work / "out"
    missing = scenes / "absent.toml"
    code, err = run_main(["simulate", "--scene", str(missing), "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (repr(str(missing)), "cannot be read", "No such file"))
    assert_nothing_left(work, out, set())


@pytest.mark.parametrize(
    ("path", "expected"), [("", "must name a file"), ("/dev/zero", "is larger than 10 MiB")]
)
def test_empty_scene_path_and_endless_device(path, expected, workspace, capsys):
    _, work = workspace
    out = work / "out"
    code, err = run_main(["simulate", "--scene", path, "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (f"scene file {path!r}", expected))
    assert_nothing_left(work, out, set())


def test_unreadable_scene_file(workspace, capsys):
    # chmod 000 does not stop root (CI runs as root), so the unreadable path is a directory
    scenes, work = workspace
    unreadable = scenes / "scene.toml"
    unreadable.mkdir()
    out = work / "out"
    code, err = run_main(["simulate", "--scene", str(unreadable), "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (repr(str(unreadable)), "cannot be read"))
    assert_nothing_left(work, out, set())


def test_out_under_a_regular_file(workspace, capsys):
    _, work = workspace
    (work / "plain").write_text("not a directory")
    out = work / "plain" / "run"
    code, err = run_main(["simulate", "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (f"--out {str(out)!r}", "is not a writable directory"))
    assert_nothing_left(work, out, {"plain"})


def test_out_is_a_regular_file(workspace, capsys):
    _, work = workspace
    out = work / "plain"
    out.write_text("not a directory")
    code, err = run_main(["simulate", "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (f"--out {str(out)!r}", "is not a directory"))
    assert out.read_text() == "not a directory"
    assert {p.name for p in work.iterdir()} == {"plain"}


def test_out_in_a_read_only_file_system(capsys):
    # /proc refuses new files even for root (root passes the permission check and fails on the
    # probe file); the refusal comes before any simulation
    out = Path("/proc/signatelec-test/run")
    code, err = run_main(["simulate", "--out", str(out)], capsys)
    assert_one_clear_line(code, err, (f"--out {str(out)!r}", "'/proc'", "writable directory"))
    assert not out.exists()


def test_empty_out(workspace, capsys):
    _, work = workspace
    before = set(os.listdir("."))
    code, err = run_main(["simulate", "--out", ""], capsys)
    assert_one_clear_line(code, err, ("--out ''", "must name a directory"))
    assert set(os.listdir(".")) == before


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (("--omega", "text"), ("'--omega'", "'text' is not a valid float")),
        (("--radial-load", "nan"), ("--radial-load nan", "must be a finite number")),
    ],
)
def test_bad_input_in_a_separate_process(args, expected, workspace):
    """The console entry point, not only main(): exit status and stderr as a user sees them."""
    _, work = workspace
    out = work / "out"
    code = "import sys; from signatelec.cli import main; main(sys.argv[1:])"
    proc = subprocess.run(
        [sys.executable, "-c", code, "simulate", *args, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    err = proc.stderr.splitlines()
    assert_one_clear_line(proc.returncode, err, expected)
    assert proc.stdout == ""
    assert_nothing_left(work, out, set())
