"""The command line: exit codes, one-line errors, outputs, reproducibility. The README's main job and
the one-line errors run in a new process, as a user runs them; the rest through cli.run (conftest)."""

from __future__ import annotations

import csv
import json
import re

import pytest

from conftest import (ROOT, SCENES, assert_picture, command_parsers, peg_scene_file, run_cli, run_process,
                      small_landing_file, write_scene)

TIMING = ("time_to_first_solution_s", "planning_time_s", "setup_time_s")


def assert_one_line_error(proc, *words):
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for w in words:
        assert w in lines[0], lines[0]


@pytest.fixture(scope="module")
def asymmetric_seed_1(tmp_path_factory):
    """`plan reference_asymmetric.yaml --seed 1` in a new process, as a user runs it, and its directory."""
    out = tmp_path_factory.mktemp("asymmetric") / "p"
    return run_process("plan", str(SCENES / "reference_asymmetric.yaml"), "--seed", "1", "--time", "1",
                       "--out", str(out)), out


def test_plan_writes_plan_and_picture(asymmetric_seed_1):
    proc, out = asymmetric_seed_1
    assert proc.returncode == 0, proc.stderr
    plan = json.loads((out / "plan.json").read_text())
    for key in ("solved", "states", "primitives", "cost", "mode_switches", "planner", "seed", "sliding_model",
                "time_to_first_solution_s"):
        assert key in plan
    assert plan["solved"] and plan["planner"] == "RRTstar" and plan["seed"] == 1
    assert_picture(out / "cspace.png")
    printed = re.findall(r"^  (\d+)\. (P_\w+),", proc.stdout, re.M)  # every primitive, numbered, with its type
    assert printed == [(str(k), p["type"]) for k, p in enumerate(plan["primitives"], 1)], proc.stdout
    # the cost against the exact lattice optimum, recorded and printed (docs/model.md 8.2: 84.5)
    assert plan["lattice_optimum"] == pytest.approx(84.5) and plan["cost"] >= plan["lattice_optimum"]
    assert f"cost {plan['cost']:.2f}" in proc.stdout and "84.50" in proc.stdout, proc.stdout


@pytest.mark.slow
def test_same_seed_same_plan(tmp_path):
    plans = []
    for k in range(2):
        out = tmp_path / str(k)
        proc = run_cli("plan", str(SCENES / "reference_upper_obstacle.yaml"), "--seed", "7", "--time", "1", "--out", str(out))
        assert proc.returncode == 0, proc.stderr
        plan = json.loads((out / "plan.json").read_text())
        for key in TIMING:
            plan.pop(key)
        plans.append(plan)
    assert plans[0] == plans[1]


@pytest.mark.slow
def test_other_seed_other_run(tmp_path, asymmetric_seed_1):
    """The seed reaches OMPL: different seeds explore differently (iterations are equal, trees are not)."""
    texts = [json.dumps(json.loads((asymmetric_seed_1[1] / "plan.json").read_text())["states"])]
    for seed in ("2", "3"):
        proc = run_cli("plan", str(SCENES / "reference_asymmetric.yaml"), "--seed", seed, "--time", "1",
                       "--out", str(tmp_path / seed))
        assert proc.returncode == 0
        plan = json.loads((tmp_path / seed / "plan.json").read_text())
        texts.append(json.dumps(plan["states"]))
    assert len(set(texts)) > 1


def test_equal_digits_has_no_secure_path():
    proc = run_cli("plan", str(SCENES / "reference_equal_digits.yaml"), "--time", "1")
    assert proc.returncode == 3
    assert "no solution" in proc.stdout and "goal region" in proc.stdout


def test_unreachable_goal_reports_lattice_proof(tmp_path):
    """A peg cuts the start off from the goal (conftest.peg_scene_file): the exact search proves
    it, and no planner runs."""
    path = peg_scene_file(tmp_path)
    proc = run_cli("plan", str(path), "--seed", "1", "--time", "0.2")
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "no secure path exists" in proc.stdout


def test_start_not_held_exits_3(tmp_path):
    path = write_scene(tmp_path, lambda d: d.update(start={"theta_deg": 80, "d": 0.8, "psi_deg": 0}))
    proc = run_cli("plan", str(path), "--time", "0.2")
    assert proc.returncode == 3
    assert "start state" in proc.stdout


@pytest.mark.parametrize("planner", ["RRTstar", "lattice"])
@pytest.mark.parametrize("start,axis", [({"theta_deg": 30, "d": 0.5, "psi_deg": 0}, "d"),
                                        ({"theta_deg": 30, "d": 0.8, "psi_deg": 50}, "psi")])
def test_goal_behind_the_start_exits_3_naming_the_coordinate(tmp_path, planner, start, axis):
    """d only falls and psi only rises: a start below the goal's d, or beyond its psi, cannot reach it."""
    path = write_scene(tmp_path, lambda d: d.update(start=start))
    proc = run_cli("plan", str(path), "--planner", planner, "--time", "0.2", "--out", str(tmp_path / "out"))
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert f"goal region lies behind the start along {axis}," in proc.stdout
    plan = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert plan["outcome"] == "goal_empty" and plan["evidence"]["behind_start"] == [axis]


def test_start_on_the_table_with_no_secure_move_exits_3(tmp_path):
    """theta 0: the lattice holds one theta value and no secure move; the exact search says why."""
    path = write_scene(tmp_path, lambda d: d.update(start={"theta_deg": 0, "d": 0.8, "psi_deg": 0}))
    proc = run_cli("plan", str(path), "--planner", "lattice", "--out", str(tmp_path / "out"))
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "start state" in proc.stdout and "Warning" not in proc.stderr


def test_regions_map(tmp_path):
    out = tmp_path / "map.png"
    proc = run_cli("regions", str(SCENES / "reference_upper_obstacle.yaml"), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert_picture(out)


BAD_SCENES = {
    "negative friction": (lambda d: d.update(friction={"G": -0.1, "A": 0.3, "B": 0.3}) or d.pop("friction_angle_deg"),
                          "friction.G"),
    "friction angle 90": (lambda d: d["friction_angle_deg"].update(A=90), "friction_angle_deg.A"),
    "both friction forms": (lambda d: d.update(friction={"G": 0.1, "A": 0.3, "B": 0.3}), "friction"),
    "missing goal": (lambda d: d.pop("goal"), "goal"),
    "unknown field": (lambda d: d.update(obstacle=[]), "obstacle"),
    "text for number": (lambda d: d["object"].update(length="long"), "object.length"),
    "zero length": (lambda d: d["object"].update(length=0), "object.length"),
    "thick object": (lambda d: d["object"].update(thickness=0.1), "object.thickness"),
    "alpha too large": (lambda d: d["digits"].update(alpha=1.5), "digits.alpha"),
    "finger length inconsistent": (lambda d: d["digits"].update(finger_length=0.01), "digits.finger_length"),
    "negative thumb": (lambda d: d["digits"].update(thumb_length=-0.01), "digits.thumb_length"),
    "start outside bounds": (lambda d: d["start"].update(d=1.5), "start.d"),
    "reversed goal range": (lambda d: d["goal"].update(d=[0.7, 0.5]), "goal.d"),
    "bad sliding model": (lambda d: d["planning"].update(sliding_model="sticky"), "planning.sliding_model"),
    "bad obstacle": (lambda d: d.update(obstacles=[{"center": [0, 0], "size": [0.01, -1]}]), "obstacles[0].size"),
}


@pytest.mark.parametrize("case", BAD_SCENES)
def test_bad_scene_exits_2_naming_the_field(tmp_path, case):
    change, field = BAD_SCENES[case]
    path = write_scene(tmp_path, change)
    before = path.read_text()
    proc = run_process("plan", str(path), "--out", str(tmp_path / "out"))
    assert_one_line_error(proc, field)
    assert path.read_text() == before
    assert not (tmp_path / "out").exists()


def test_missing_scene_file():
    assert_one_line_error(run_process("plan", "no/such/scene.yaml"), "no such file")


def test_malformed_yaml(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("object: {length: 0.06\nfriction: [")
    assert_one_line_error(run_process("plan", str(path)), "YAML")


def test_scene_not_a_mapping(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- 1\n- 2\n")
    assert_one_line_error(run_process("plan", str(path)), "mapping")


@pytest.mark.parametrize("args,word", [
    (("--planner", "RRTfast"), "unknown planner"),
    (("--time", "-1"), "time"),
    (("--seed", "-3"), "seed"),
    (("--iterations", "0"), "iterations"),
    (("--time", "soon"), "--time: must be a number"),
])
def test_bad_options_exit_2(args, word):
    """Answered before anything runs: no seed drawn and printed for options that cannot plan."""
    proc = run_process("plan", str(SCENES / "reference_asymmetric.yaml"), *args)
    assert_one_line_error(proc, word)
    assert proc.stdout == "", proc.stdout


def test_out_must_be_a_directory(tmp_path):
    existing = tmp_path / "file"
    existing.write_text("keep me")
    assert_one_line_error(run_process("plan", str(SCENES / "reference_asymmetric.yaml"), "--out", str(existing)), "--out")
    assert existing.read_text() == "keep me"


def test_unknown_command_exits_2():
    assert_one_line_error(run_process("fly"), "command: must be one of plan, ")


@pytest.mark.parametrize("args,line", [
    (("plan", "guitar_pick", "--time", "-1"), "--time: must be > 0, got -1"),
    (("bench", "guitar_pick", "--runs", "x"), "--runs: must be an integer, got 'x'"),
    (("plan", "guitar_pick", "--objective", "fast"), "--objective: must be one of cost, margin, balanced, tolerance, got 'fast'"),
    (("plan",), "scene: is required"),
    (("plan", "guitar_pick", "--bogus"), "--bogus: is not an argument of this command (see --help)"),
])
def test_argument_errors_name_the_argument(args, line):
    """argparse's complaints read like every other bad input: the argument, then the reason."""
    proc = run_process(*args)
    assert proc.returncode == 2 and proc.stderr == f"ungrasp-ompl: error: {line}\n", proc.stderr


@pytest.mark.slow
def test_bench_and_sweep_commands(tmp_path):
    """The commands a user runs: a tiny benchmark and sweep, each writing its files."""
    out = tmp_path / "b"
    proc = run_cli("bench", str(SCENES / "reference_asymmetric.yaml"), "--planners", "RRTConnect,lattice",
                   "--runs", "1", "--time", "0.3", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert (out / "benchmark.db").is_file() and (out / "summary.csv").is_file()
    with open(out / "summary.csv", newline="") as f:
        rows = {r["planner"]: r for r in csv.DictReader(f)}
    assert float(rows["lattice"]["gap_to_optimum_percent"]) == 0.0  # the yardstick is its own optimum
    table = [line for line in proc.stdout.splitlines() if not line.startswith("wrote ")]
    assert max(map(len, table)) <= 100  # the printed table and its notes fit 100 columns
    proc = run_cli("sweep", str(SCENES / "reference_asymmetric.yaml"), "--alpha", "0:0.47:0.47", "--runs", "1",
                   "--time", "0.3", "--out", str(tmp_path / "s"))
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "s" / "sweep.csv").is_file() and (tmp_path / "s" / "sweep.png").is_file()
    assert_one_line_error(run_cli("bench", str(SCENES / "reference_asymmetric.yaml"), "--planners", "RRTfast"),
                          "--planners")
    assert_one_line_error(run_cli("sweep", str(SCENES / "reference_asymmetric.yaml"), "--alpha", "x"), "--alpha")


def test_errors_name_a_shipped_scene_by_its_name():
    """A shipped scene's error names it as the user typed it, not by its path inside the package."""
    proc = run_process("simulate", "reference_asymmetric")
    assert proc.returncode == 2
    assert proc.stderr == ("ungrasp-ompl: error: reference_asymmetric: object.thickness: the simulator needs an "
                           "object with a thickness (m)\n")


@pytest.mark.slow
def test_progress_in_a_pipe_is_a_line_per_tenth(tmp_path):
    """stderr to a pipe or a log: plain lines, no carriage returns (one endless line otherwise)."""
    proc = run_cli("bench", "reference_asymmetric", "--planners", "lattice", "--runs", "2", "--time", "0.1",
                   "--jobs", "1", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and "\r" not in proc.stdout
    assert proc.stderr.splitlines()[-1].startswith("bench: 2/2 runs after "), proc.stderr


def test_progress_on_a_terminal_is_a_bar_with_rate_and_time_left(monkeypatch):
    import io

    from ungrasp_ompl.cli.progress import Progress as _Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    err = Terminal()
    monkeypatch.setattr("sys.stderr", err)
    bar = _Progress("trials", "simulate")
    for k in range(4):
        bar.show(k, 4, f"trial {k}")
    assert bar.bar is not None and _Progress.open == [bar]
    bar.show(4, 4)
    assert _Progress.open == [] and err.getvalue().endswith("\n")
    last = err.getvalue().rstrip("\n").rsplit("\r", 1)[-1]
    assert last.startswith("simulate: 100%") and "4/4 [" in last and "trials/s" in last, last
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d, ", last), last  # time spent < time left


@pytest.mark.slow
def test_unseeded_plan_draws_a_seed_that_repeats_it(tmp_path):
    """Without --seed a seed is drawn, printed and kept in plan.json (which --export writes too);
    planning again with it gives the same plan, and cage takes the export directory as --plan."""
    scene = str(small_landing_file("guitar_pick", tmp_path))
    for _ in range(3):  # 2 of the 9,999 seeds it draws find no path in 1 s (exit 3): draw again
        first = run_cli("plan", scene, "--time", "1", "--export", str(tmp_path / "a"))
        if first.returncode != 3:
            break
    assert first.returncode == 0, first.stderr
    m = re.search(r"^seed (\d+) \(pass --seed (\d+) to repeat\)$", first.stdout, re.M)
    assert m and m[1] == m[2], first.stdout
    drawn = json.loads((tmp_path / "a" / "plan.json").read_text())
    assert drawn["seed"] == int(m[1])
    again = run_cli("plan", scene, "--time", "1", "--seed", m[1], "--out", str(tmp_path / "b"))
    assert again.returncode == 0 and "pass --seed" not in again.stdout
    repeated = json.loads((tmp_path / "b" / "plan.json").read_text())
    for key in ("states", "primitives", "cost", "iterations", "seed"):
        assert repeated[key] == drawn[key], key
    cage = run_cli("cage", scene, "--plan", str(tmp_path / "a"))
    assert cage.returncode == 0 and "warning" not in cage.stdout, cage.stdout + cage.stderr


@pytest.mark.parametrize("planner", ["lattice", "RRTstar"])
def test_a_plan_read_back_has_the_primitives_the_planner_gave_as_typed_values(tmp_path, planner):
    """plan.json read back gives the planner's primitives, field for field and type for type (each
    a Primitive), so that what is computed from a plan (a trial's set-up, the landing kept under its
    digest) is the same for the plan and for its file."""
    from ungrasp_ompl import Scene, plan
    from ungrasp_ompl.mechanics.contact import Primitive
    from ungrasp_ompl.planning.result import read_plan

    planned = plan(Scene.from_file("guitar_pick"), planner=planner, seed=1, time=1.0)
    (tmp_path / "plan.json").write_text(planned.to_json())
    read = read_plan(tmp_path / "plan.json")
    assert read.primitives == planned.primitives
    assert {type(p.type) for p in read.primitives + planned.primitives} == {Primitive}


def test_plan_read_back_is_checked_field_by_field(tmp_path):
    """A plan.json hand-edited or cut short: one line naming the field and the reason."""
    from ungrasp_ompl.errors import InputError
    from ungrasp_ompl.planning.result import read_plan

    golden = json.loads((SCENES.parent / "tests" / "golden" / "reference_asymmetric.json").read_text())
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(golden))
    assert read_plan(tmp_path).states == golden["states"]  # a directory holding one

    def refused(doc, field, words):
        path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
        with pytest.raises(InputError) as exc:
            read_plan(path)
        assert exc.value.field == field and words in exc.value.reason, str(exc.value)

    refused(json.dumps(golden)[:500], "plan", "is not valid JSON (cut short or mistyped?) at line 1, column 501")
    far = json.loads(json.dumps(golden))
    far["primitives"][1]["waypoints"][-1][1] = 1e300  # d of 1e300 object lengths
    refused(far, "primitives[1].waypoints[1]", "must lie within theta [0, pi/2] rad, d [0, 1]")
    broken = json.loads(json.dumps(golden))
    broken["primitives"][2]["waypoints"][0][0] += 0.1  # no longer where primitive 1 ended
    refused(broken, "primitives[2].waypoints[0]", "must be where the path is before it")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError) as err:
        read_plan(empty)
    assert err.value.field == "plan"


def test_the_objective_flag_offers_every_objective():
    from ungrasp_ompl.cli.parser import OBJECTIVE_NAMES
    from ungrasp_ompl.planning.margins import OBJECTIVES

    assert OBJECTIVE_NAMES == tuple(o.value for o in OBJECTIVES)


def test_simulate_help_names_every_perturbation_preset():
    from ungrasp_ompl.scene.perturbation import PRESETS

    simulate = command_parsers()["simulate"]
    text = " ".join(simulate.format_help().split())
    assert all(name in text for name in PRESETS), [n for n in PRESETS if n not in text]


def test_the_synopsis_in_docs_cli_names_every_command_and_flag():
    """docs/cli.md's synopses (`ungrasp-ompl COMMAND ...` in its code blocks) name every command
    and each command's every flag, as the parser has them, and no flag it does not have."""
    commands = command_parsers()
    blocks = (ROOT / "docs" / "cli.md").read_text().split("```")[1::2]
    synopsis: dict[str, set[str]] = {}
    for block in blocks:
        name = None
        for line in block.splitlines():
            if m := re.match(r"ungrasp-ompl (\w+)", line):
                name = m.group(1)
                synopsis.setdefault(name, set())
            if name is not None and (m or line.startswith(" ")):
                synopsis[name] |= set(re.findall(r"--[a-z][\w-]*", line))
    assert sorted(synopsis) == sorted(commands)
    for name, parser in commands.items():
        flags = {s for a in parser._actions for s in a.option_strings if s.startswith("--") and s != "--help"}
        assert synopsis[name] == flags, (name, sorted(flags - synopsis[name]), sorted(synopsis[name] - flags))


def test_every_key_of_plan_json_is_in_its_document(asymmetric_seed_1, tmp_path):
    """Every key plan.json holds (at the top, in a primitive, the friction, the tolerance, the
    manipulation plane and its contacts, the stability report), for a planar scene and an object, is
    named in docs/plan-json.md."""
    r = run_cli("plan", "guitar_pick", "--seed", "1", "--time", "1", "--out", str(tmp_path / "pick"))
    assert r.returncode == 0, r.stderr
    named = set(re.findall(r"`(\w+)`", (ROOT / "docs" / "plan-json.md").read_text()))
    keys = set()
    for path in (asymmetric_seed_1[1], tmp_path / "pick"):
        doc = json.loads((path / "plan.json").read_text())
        parts = [doc, *doc["primitives"], doc["tolerance"], doc["tolerance"]["physical"], doc["friction"]]
        if doc["manipulation_plane"] is not None:  # null for a planar scene, as object and the report are
            plane, report = doc["manipulation_plane"], doc["stability_report"]
            parts += [doc["object"], plane, *plane["contacts"].values(), report, report["x_moments"],
                      *report["roll_simulation"], *report["contacts"].values()]
        keys |= {k for part in parts for k in part}
    assert "manipulation_plane" in keys and "across_support_m" in keys  # the object's plan was read
    assert keys <= named, sorted(keys - named)


def test_the_readme_has_one_example_per_command_and_each_parses():
    """The README's examples (one per command) are command lines the parser takes as they stand."""
    import shlex

    from ungrasp_ompl.cli.parser import build_parser

    section = (ROOT / "README.md").read_text().split("## The commands, one example each", 1)[1]
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    parser = build_parser()
    shown = []
    for line in block.splitlines():
        words = shlex.split(line, comments=True)
        assert words[0] == "ungrasp-ompl", line
        shown.append(parser.parse_args(words[1:]).command)
    assert sorted(set(shown)) == sorted(command_parsers())
