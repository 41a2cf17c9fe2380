"""The figures the pages quote come from the results files the tools write (docs/results/), so that
no two pages can disagree: every marked figure and table of README.md and docs/results.md is what
tools/campaign_results.py builds from its file, the JSON of a campaign holds its table's figures,
no count stands on a page outside a mark, and the README's first example is what its command prints."""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import json
import math
import re

import pytest

from conftest import ROOT, run_cli

PAGES = ("README.md", "docs/results.md")
#: The step convergence study's files (record 0111), each run at one step.
STEP_TABLES = ("campaigns_step_0.1ms", "campaigns_step_0.05ms", "campaigns_step_0.025ms", "campaigns_step_0.0125ms",
               "campaigns_step_0.00625ms")
#: Campaign files whose footer this check cannot split: a Drake hull named in the step, before the rule.
UNSPLIT_FOOTERS = ("campaigns_drake_fanned_hull", "campaigns_drake_tangram_fanned_hull")
#: The campaign tables tools/sim_campaigns.py wrote, each with its JSON beside it (a study's file,
#: written by another tool, has no table).
TABLES = tuple(sorted(p.stem for p in (ROOT / "docs" / "results").glob("campaigns*.md")
                      if p.stem not in UNSPLIT_FOOTERS and "table" in json.loads(p.with_suffix(".json").read_text())))
#: What the Drake campaign's rows hold beside its table's figures: MuJoCo's row and the Fisher test.
ENGINE_KEYS = ("mujoco", "fisher_p")


def _tool():
    spec = importlib.util.spec_from_file_location("campaign_results", ROOT / "tools" / "campaign_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


results = _tool()


def _rows(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("| ")][1:]  # the header aside


@pytest.mark.parametrize("name", TABLES)
def test_a_campaign_s_json_holds_its_table(name):
    """The JSON beside a campaign table has the table's rows, figure for figure, and its footer's."""
    table = (ROOT / "docs" / "results" / f"{name}.md").read_text()
    doc = json.loads((ROOT / "docs" / "results" / f"{name}.json").read_text())
    assert doc["table"] == f"docs/results/{name}.md"
    assert doc["command"].startswith("python tools/sim_campaigns.py ") and "--table" in doc["command"]
    assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", doc["produced"])
    parsed = results.parse_table(table)
    assert [{k: v for k, v in r.items() if k not in ENGINE_KEYS} for r in doc["rows"]] == parsed["rows"]
    assert {k: doc[k] for k in parsed if k != "rows"} == {k: v for k, v in parsed.items() if k != "rows"}
    assert [results.row_line(r) for r in doc["rows"]] == _rows(table)


@pytest.mark.parametrize("name", TABLES)
def test_a_campaign_s_intervals_and_totals_follow_from_its_counts(name):
    """Each row's interval is the Wilson 95 % interval of its count, and a row over the three
    objects sums the three rows before it."""
    from ungrasp_ompl.sim.campaign import wilson_interval

    doc = results.load(name)
    for r in doc["rows"]:
        lo, hi = wilson_interval(r["successes"], r["trials"])
        assert r["interval_percent"] == [round(100 * lo), round(100 * hi)], r["label"]
        assert 0 <= r["successes"] <= r["trials"] and 0 <= r["placed"] <= r["trials"], r["label"]
    rows = doc["rows"]
    totals = [k for k, r in enumerate(rows) if r["subject"] == "the three objects"]
    # a file with the base rows has their total (the curved rows are other objects; a step study's
    # file may hold worlds alone)
    assert totals or not any(r["campaign"] == "base" for r in rows)
    for k in totals:
        three = rows[k - 3:k]
        assert [r["object"] for r in three] == list(results.OBJECTS)
        assert rows[k]["successes"] == sum(r["successes"] for r in three)
        assert rows[k]["trials"] == sum(r["trials"] for r in three)
        assert rows[k]["placed"] == sum(r["placed"] for r in three)


def _fisher_two_sided(a: int, n: int, b: int, m: int) -> float:
    """The two-sided Fisher exact test's p of a/n against b/m from the hypergeometric law: the
    probability of every table with the same margins no likelier than the one seen."""
    from math import comb

    k, total = a + b, n + m
    prob = [comb(n, x) * comb(m, k - x) / comb(total, k) for x in range(max(0, k - m), min(n, k) + 1)]
    seen = comb(n, a) * comb(m, b) / comb(total, k)
    return min(1.0, sum(q for q in prob if q <= seen * (1 + 1e-7)))


@pytest.mark.parametrize("name, tangram", [("campaigns_drake", False), ("campaigns_drake_fanned_hull", False),
                                           ("campaigns_drake_base", False),
                                           ("campaigns_drake_tangram", True), ("campaigns_drake_tangram_fanned_hull", True)])
def test_the_drake_campaign_sets_each_row_beside_mujoco_s(name, tangram):
    """Each Drake row holds MuJoCo's row of the same key in the MuJoCo file it names, figure for
    figure, and the two-sided Fisher test's p of the two counts (each over its own trials); the
    tangram's rows have a file of their own, set beside MuJoCo's tangram file."""
    doc = results.load(name)
    source = doc["mujoco_source"]
    assert source.startswith("docs/results/") and source.endswith(".json")
    mujoco = results.load(source.removeprefix("docs/results/").removesuffix(".json"))
    theirs = {r["key"]: r for r in mujoco["rows"]}
    assert doc["mujoco_command"] == mujoco["command"]
    assert doc["rows"] and all(r["campaign"].startswith("tangram") == tangram for r in doc["rows"])
    for r in doc["rows"]:
        m = theirs[r["key"]]
        assert r["mujoco"] == {k: m[k] for k in r["mujoco"]} and r["mujoco"]["trials"] == m["trials"], r["key"]
        expected = _fisher_two_sided(r["successes"], r["trials"], m["successes"], m["trials"])
        assert r["fisher_p"] == pytest.approx(expected, rel=1e-9), r["key"]


def test_the_fisher_oracle_knows_a_textbook_table():
    """The oracle above on Fisher's tea-tasting table (3 of 4 against 1 of 4: p = 34/70) and on a
    table of two equal counts (p = 1)."""
    assert _fisher_two_sided(3, 4, 1, 4) == pytest.approx(34 / 70, rel=1e-12)
    assert _fisher_two_sided(10, 10, 40, 40) == 1.0


@pytest.mark.parametrize("page", PAGES)
def test_every_marked_figure_is_its_results_file_s(page):
    text = (ROOT / page).read_text()
    assert len(results.FIG.findall(text)) >= 2 and len(results.TABLE.findall(text)) >= 2, page
    assert results.differences(text) == []


#: The other pages that quote results files: the model and the decision records with a mark.
QUOTING = ("docs/model.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs" / "decisions").glob("0*.md")
                                      if "<!-- fig " in p.read_text() or "<!-- table " in p.read_text()))


@pytest.mark.parametrize("page", QUOTING)
def test_every_other_page_s_marked_figure_is_its_results_file_s(page):
    """A decision record quotes its runs as the pages do: a file merged into after the record
    still gives it the figures and the commands it quoted (each merged run by its place, rerun-K)."""
    assert results.differences((ROOT / page).read_text()) == []


def test_a_merged_run_is_quoted_by_its_place():
    """rerun-K is the K-th run merged into a file after its first, in the order they ran; reruns
    lists them all, and a K past the last is refused."""
    doc = results.load("campaigns_heading_record_0137")
    later = [r for r in doc["runs"].values() if r["command"] != doc["command"]]
    assert len(later) >= 2
    quoted = [results.figure(f"campaigns_heading_record_0137:rerun-{k}") for k in range(1, len(later) + 1)]
    assert [q.split("`")[1] for q in quoted] == [r["command"] for r in later]
    assert results.figure("campaigns_heading_record_0137:reruns") == "; ".join(quoted)
    with pytest.raises(KeyError):
        results.figure(f"campaigns_heading_record_0137:rerun-{len(later) + 1}")


def test_a_figure_that_differs_from_its_file_is_found():
    """The check finds a changed figure, in a table and in a sentence, and a row the file lacks."""
    text = (ROOT / "docs" / "results.md").read_text()
    table = results.TABLE.search(text)
    count = re.search(r"(\d+)/(\d+)", table.group(3))
    other = f"{(int(count.group(1)) + 1) % (int(count.group(2)) + 1)}/{count.group(2)}"
    changed = text.replace(table.group(3), table.group(3).replace(count.group(0), other, 1), 1)
    assert len(results.differences(changed)) == 1
    figure = results.FIG.search(text)
    changed = text.replace(figure.group(0), figure.group(0).replace(figure.group(2), figure.group(2) + "0"), 1)
    assert len(results.differences(changed)) == 1
    with pytest.raises(KeyError):
        results.figure("campaigns:no-such-row:strict")


def _prose(text: str) -> str:
    """A page without its code (fenced blocks and spans), its marked figures and tables and comments."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    text = results.TABLE.sub("", text)
    text = results.FIG.sub("", text)
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    return re.sub(r"`[^`]*`", "", text)


@pytest.mark.parametrize("page", (*PAGES, "docs/cli.md"))
def test_no_count_or_measured_millimetre_outside_a_mark(page):
    """A success count (k/n), or a measured length in mm to the hundredth, stands on a page only
    inside a mark, where the check reads it from its file."""
    prose = _prose((ROOT / page).read_text())
    assert re.findall(r"\b\d+/\d+\b", prose) == []
    if page in PAGES:
        assert re.findall(r"\b\d+\.\d{2,} mm\b", prose) == []


def _timeless(lines: list[str]) -> list[str]:
    """Lines with their durations (the machine's) made X s."""
    return [re.sub(r"\d+\.\d+ s\b", "X s", line) for line in lines]


def test_the_readme_quotes_what_its_first_example_prints(tmp_path, monkeypatch):
    """The README's first example is the set-up's main job, and its quoted output is what the
    command prints, line for line, the durations aside."""
    readme = (ROOT / "README.md").read_text()
    setup = readme.split("## Set-up: two commands", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    main_job = setup.splitlines()[1].split(" && ")[-1]
    assert main_job == ".venv/bin/ungrasp-ompl plan guitar_pick --seed 1 --export out"
    quoted = readme.split("## A first example", 1)[1].split("```\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    proc = run_cli(*main_job.split()[1:])
    assert proc.returncode == 0, proc.stderr
    assert _timeless(proc.stdout.splitlines()) == _timeless(quoted.splitlines())
    assert (tmp_path / "out" / "trajectory.csv").stat().st_size > 0


# --- the studies' results files (tools/landing_check.py, tools/world_failures.py --results) ---------

#: The results files of a study tool, and the tool that writes each.
STUDIES = {"landing_check": "tools/landing_check.py", "world_failures": "tools/world_failures.py",
           "sliding_drift": "tools/sliding_drift.py", "tangram_gaps": "tools/tangram_gaps.py"}
#: The studies docs/model.md's sections 11.17 and 11.18 quote.
MODEL_STUDIES = {"landing_check", "landing_errors", "landing_offset", "landing_map", "world_failures", "sliding_drift"}


def _model_sections() -> str:
    """docs/model.md's sections 11.17 and 11.18, whose figures come from the studies' files."""
    text = (ROOT / "docs" / "model.md").read_text()
    return "### 11.17" + text.split("### 11.17", 1)[1].split("### 11.19", 1)[0]


@pytest.mark.parametrize("name", STUDIES)
def test_a_study_s_markdown_is_rendered_from_its_json(name):
    """The markdown beside a study's JSON is what the JSON renders; each row's key is made from its
    label and is the file's only such key; each study names the command that wrote it."""
    doc = results.load(name)
    assert (ROOT / "docs" / "results" / f"{name}.md").read_text() == results.study_markdown(doc) + "\n"
    keys = [r["key"] for r in doc["rows"]]
    assert keys == [results.row_key(r["label"]) for r in doc["rows"]] and len(set(keys)) == len(keys)
    studies = [r for r in doc["rows"] if r["label"].startswith("study: ")]
    assert studies
    for s in studies:
        assert s["command"].startswith(f"python {STUDIES[name]} ") and "--results" in s["command"], s["command"]
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", s["produced"]) and s["seconds"] > 0
        assert any(r.get("study") == s["study"] for r in doc["rows"] if r is not s)


def test_the_margin_s_counts_follow_from_its_trials():
    """world_failures: each world's counts are its trials' own, recounted; the totals sum them; a
    world that sets the friction runs every trial at exactly its factor (decision 0100) and the
    nominal world at the trials' own draws."""
    doc = results.load("world_failures")
    trials = [r for r in doc["rows"] if r["label"].startswith("trial: ")]
    worlds = [r for r in doc["rows"] if r.get("study") == "trials" and "first_below" in r]
    assert trials and worlds
    for w in worlds:
        mine = [t for t in trials if (t["object"], t["world"]) == (w["object"], w["world"])]
        assert len(mine) == w["trials"]
        assert w["held"] == sum(t["held"] for t in mine)
        assert w["predicted_held"] == sum(t["predicted"] == "held" for t in mine)
        assert w["right"] == sum((t["predicted"] == "held") == t["held"] for t in mine)
        assert w["failures_predicted"] == sum(t["predicted"] != "held" and not t["held"] for t in mine)
        assert sum(n for n, _ in w["outcomes"]) == w["trials"]
        if w["world"].startswith("friction x"):
            factor = float(w["world"].removeprefix("friction x"))
            assert all([t["factor_g"], t["factor_a"], t["factor_b"]] == [factor] * 3 for t in mine), w["label"]
        if w["world"] == "as modelled":
            assert any(t["factor_g"] < 1.0 for t in mine)
    everything = next(r for r in doc["rows"] if r["label"] == "trials: all worlds")
    assert everything["trials"] == len(trials) == sum(w["trials"] for w in worlds)
    assert everything["right"] == sum(w["right"] for w in worlds)
    assert everything["failures_predicted"] == sum(w["failures_predicted"] for w in worlds)


def test_the_landing_differences_follow_from_the_landings():
    """landing_check: model - simulated is each model landing less the simulated one; a trial that
    lost the object has no landing; n counts the placed trials of at most five: at least those the
    strict verdict placed, at most those that did not lose their grip (a strict failure such as a
    turn out of the plane may still be placed by the paper's criterion; a lost grip ends a trial)."""
    doc = results.load("landing_check")
    rows = [r for r in doc["rows"] if "world" in r]
    assert rows
    for r in rows:
        if r["sim_placed"]:
            assert r["model_minus_sim_mm"] == pytest.approx([m - r["sim_along_mm"] for m in r["model_mm"]])
        else:
            assert r["sim_along_mm"] is None and r["model_minus_sim_mm"] is None
        placed = sum(o in ("success", "placed off target") for o in r["draw_outcomes"])
        held = sum(not o.startswith("grip lost") for o in r["draw_outcomes"])
        assert placed + r["sim_placed"] <= r["n"] <= held + r["sim_placed"] <= 1 + len(r["draw_outcomes"])


def test_the_drift_rows_pair_the_two_cones_on_the_same_trials():
    """sliding_drift: each object has one row per cone, over the same number of trials; the mean
    drift is at most the largest; the spread is a standard deviation; no more successes than trials."""
    doc = results.load("sliding_drift")
    rows = [r for r in doc["rows"] if "trials" in r]
    by_object: dict[str, dict] = {}
    for r in rows:  # "[study: ]object, cone"; a study's name may hold a comma
        name, cone = r["label"].rsplit(", ", 1)
        by_object.setdefault(name, {})[cone] = r
    assert rows and len(rows) == 2 * len(by_object)
    for mine in by_object.values():
        assert set(mine) == {"elliptic", "pyramidal"}
        assert mine["elliptic"]["trials"] == mine["pyramidal"]["trials"] >= 2
        for r in mine.values():
            assert 0.0 <= r["b_drift_mean_mm"] <= r["b_drift_max_mm"]
            assert r["landing_across_sd_mm"] >= 0.0 and 0 <= r["successes"] <= r["trials"]


def test_merging_a_study_keeps_the_others(tmp_path):
    """A study written again replaces its own rows and keeps the other studies'; two rows with one
    key are refused, and a prefixed study's labels begin with its name."""
    path = tmp_path / "study.json"
    results.merge_study(path, "a", "python x --results", 1.0, [{"label": "a: one", "v": 1.0}], {"v": "{:.1f}"}, "t")
    results.merge_study(path, "b", "python x --results", 2.0, [{"label": "b: one", "v": 2.0}], {}, "t")
    results.merge_study(path, "a", "python x --results", 3.0, [{"label": "a: two", "v": 3.0}], {}, "t")
    doc = json.loads(path.read_text())
    assert [r["key"] for r in doc["rows"]] == ["study-b", "b-one", "study-a", "a-two"]
    assert path.with_suffix(".md").read_text() == results.study_markdown(doc) + "\n"
    with pytest.raises(ValueError):
        results.merge_study(path, "c", "python x --results", 1.0, [{"label": "b: one"}], {}, "t")
    results.merge_study(path, "c", "python x --results", 1.0, [{"label": "one"}], {}, "t", prefixed=True)
    assert [r["label"] for r in json.loads(path.read_text())["rows"]][-1] == "c: one"


def test_the_model_s_release_and_world_sections_quote_their_files():
    """docs/model.md 11.17 and 11.18: every marked figure and table is its file's, the figures and
    tables come from the studies' files, and no count (k/n), millimetre to the hundredth,
    newton to the hundredth or old-rule friction factor stands outside a mark."""
    text = _model_sections()
    assert results.differences(text) == []
    sources = {m.split(":", 1)[0] for m in results.FIG.findall(text) for m in [m[0]]}
    sources |= {m[1].split(":", 1)[0] for m in results.TABLE.findall(text)}
    assert sources == MODEL_STUDIES
    prose = _prose(text)
    assert re.findall(r"\b\d+/\d+\b", prose) == []
    assert re.findall(r"[-+]?\b\d+\.\d{2,} (?:mm|N)\b", prose) == []
    assert "x0.56" not in prose


def test_a_study_figure_that_differs_from_its_file_is_found():
    """The check finds a changed figure of a study's file and refuses a field its row lacks."""
    text = _model_sections()
    figure = results.FIG.search(text)
    changed = text.replace(figure.group(0), figure.group(0).replace(figure.group(2), figure.group(2) + "9"), 1)
    assert len(results.differences(changed)) == 1
    row = next(r for r in results.load("world_failures")["rows"] if r["label"].startswith("trials: "))
    with pytest.raises(KeyError):
        results.figure(f"world_failures:{row['key']}:no_such_field")


def test_a_table_mark_with_no_rows_yet_renders_without_taking_the_text_after_it():
    """A page being written holds a table's marks with no rows between them; rendering fills that
    table and every other one and keeps the text between them."""
    tool = _tool()
    page = ("<!-- table campaigns:objects -->\n<!-- /table -->\nthe text between\n"
            "<!-- table campaigns:worlds -->\nstale rows\n<!-- /table -->\nthe end\n")
    rendered = tool.render(page)
    assert rendered == (f"<!-- table campaigns:objects -->\n{tool.table('campaigns:objects')}\n<!-- /table -->\n"
                        f"the text between\n<!-- table campaigns:worlds -->\n{tool.table('campaigns:worlds')}\n"
                        "<!-- /table -->\nthe end\n")
    assert tool.render(rendered) == rendered


def test_a_merged_run_replaces_its_groups_rows_whatever_their_labels_now(tmp_path):
    """Merging a run of one row group (--merge) drops that group's rows from the table, also those
    whose labels the run no longer makes, and keeps every other group's rows as they were."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    old = results.load("campaigns_pick_previous_start")
    caging = [r for r in old["rows"] if r["campaign"].startswith("caging")]
    assert len(caging) == 2
    table = tmp_path / "t.md"
    table.write_text((ROOT / "docs/results/campaigns_pick_previous_start.md").read_text())
    (tmp_path / "t.json").write_text(json.dumps(old))
    renamed = campaigns.Row.from_record(caging[0])
    renamed = dataclasses.replace(renamed, label=renamed.label.replace("+2 deg", "+9 deg"))
    footer = table.read_text().strip().splitlines()[-1].replace("7326 s in all", "12 s in all")
    merged, _, _, _ = campaigns.merge_rows(table, [renamed], footer, {"caging"})
    labels = [r["label"] for r in merged]
    assert [c for c in labels if c.startswith("caging")] == [renamed.label]
    assert [r["key"] for r in merged if not r["campaign"].startswith("caging")] == \
        [r["key"] for r in old["rows"] if not r["campaign"].startswith("caging")]


def _step_doc(step_ms: float, counts: dict[str, int], world: str = "pyramidal cones") -> dict:
    """A campaign file run at one step with a row per object in world (strict successes of 40)."""
    rows = [results.parse_row(f"| world: {o}, {world} | {n}/40 (0-0 %) | {n}/40 (-) | - | - | secure | - | - |")
            for o, n in counts.items()]
    return {"table": "t.md", "step": f"timestep {step_ms:g} ms", "rows": rows}


def test_the_step_rule_takes_the_coarsest_step_every_finer_one_agrees_from():
    """Record 0111's rule on made-up counts, against the rule's own words checked by the Fisher
    oracle: the coarsest step at which every object's count, and every finer step's, agrees with
    the finest's (p >= 0.05); where the finest and the next coarser disagree, the finest, flagged."""
    steps = (0.1, 0.05, 0.025, 0.0125)
    rising = {"guitar_pick": (0, 4, 36, 39), "puzzle_piece": (0, 30, 20, 38), "fabric_chalk": (1, 18, 37, 40)}
    docs = [_step_doc(t, {o: c[k] for o, c in rising.items()}) for k, t in enumerate(steps)]
    entry = results.step_study(*docs)["pyramidal cones"]
    agree = [all(_fisher_two_sided(c[k], 40, c[-1], 40) >= 0.05 for c in rising.values()) for k in range(4)]
    assert agree == [False, False, False, True] and entry["step_ms"] == 0.0125 and entry["converged"] is False
    settled = {"guitar_pick": (0, 37, 39, 40), "puzzle_piece": (2, 35, 38, 37), "fabric_chalk": (5, 36, 40, 39)}
    docs = [_step_doc(t, {o: c[k] for o, c in settled.items()}) for k, t in enumerate(steps)]
    entry = results.step_study(*docs)["pyramidal cones"]
    assert entry["steps"] == list(steps) and entry["step_ms"] == 0.05 and entry["converged"] is True
    with pytest.raises(ValueError):
        results.step_ms({"table": "t.md", "step": "the scenes' own step"})


def test_the_steps_are_the_ones_their_study_gives():
    """sim.pyramidal_timestep's default is the step record 0111's rule gives the pyramidal world,
    and sim.timestep's the step record 0112's rule gives the elliptic one, from the study's files,
    each run at one step."""
    from ungrasp_ompl.scene.options import SimOptions

    docs = [results.load(name) for name in STEP_TABLES]
    study = results.step_study(*docs)
    assert SimOptions().pyramidal_timestep == pytest.approx(study["pyramidal cones"]["step_ms"] / 1000, rel=1e-9)
    assert SimOptions().timestep == pytest.approx(results.elliptic_step(study) / 1000, rel=1e-9)
    for doc in docs:
        assert "--timestep" in doc["command"] and doc["step"] == f"timestep {results.step_ms(doc):g} ms"


def test_a_merged_run_of_some_worlds_keeps_the_other_worlds_rows(tmp_path, monkeypatch):
    """--worlds with --merge replaces the rows of the worlds it ran and keeps the other worlds'."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    old = results.load("campaigns")
    worlds = [r for r in old["rows"] if r["campaign"] == "world"]
    pyramidal = [r for r in worlds if r["subject"].endswith("pyramidal cones")]
    assert len(pyramidal) == 3 and len(worlds) > 3
    table = tmp_path / "t.md"
    table.write_text((ROOT / "docs/results/campaigns.md").read_text())
    (tmp_path / "t.json").write_text(json.dumps(old))
    def other(r):  # another count of the same trials
        return r["successes"] - 1 if r["successes"] > 0 else 1

    again = [dataclasses.replace(campaigns.Row.from_record(r), successes=other(r)) for r in pyramidal]
    footer = table.read_text().strip().splitlines()[-1]
    footer = "12 s in all; " + footer.split(" s in all; ", 1)[1]
    monkeypatch.setattr(campaigns, "WORLD_LABELS", ("pyramidal cones",))
    merged, runs, _, _ = campaigns.merge_rows(table, again, footer, {"worlds"})
    by_key = {r["key"]: r for r in merged}
    assert [by_key[r["key"]]["successes"] for r in pyramidal] == [other(r) for r in pyramidal]
    kept = [r for r in worlds if r not in pyramidal]
    assert all(by_key[r["key"]] == results.parse_row(results.row_line(r)) for r in kept)
    assert "worlds: pyramidal cones" in runs


def test_runs_of_the_same_worlds_with_another_tip_or_heading_keep_their_own_entries(monkeypatch):
    """A merged file's `runs` keeps every run's command: runs of the same worlds and objects that
    differ in the finger tip or the targets' turn make other rows, and each gets a name of its own
    (so that a later run does not take an earlier one's place in the file)."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    monkeypatch.setattr(campaigns, "WORLD_LABELS", ("pyramidal cones",))
    monkeypatch.setattr(campaigns, "SELECTED", ("guitar_pick",))
    names = set()
    for tip, turn in (("rounded", 0.0), ("rounded", 45.0), ("flat", 45.0), ("flat", 0.0)):
        monkeypatch.setattr(campaigns, "WORLD_TIP", tip)
        monkeypatch.setattr(campaigns, "TARGET_TURN_DEG", turn)
        names.add(campaigns._run_name({"worlds"}))
    assert len(names) == 4 and "worlds: pyramidal cones, guitar_pick" in names


def test_a_turned_target_turns_the_plane_and_nothing_else():
    """--turn-target (record 0137): the scene's GB turns by the angle about the vertical, its
    object, digits, friction and planning left as they were."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    for name, turn in (("fabric_chalk", 30.0), ("puzzle_piece", -45.0)):
        scene, turned = campaigns._scene(name), campaigns._scene(name, turn_deg=turn)
        a, b = scene.plane.frame[:3, 0], turned.plane.frame[:3, 0]
        assert math.degrees(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0])) % 360 == pytest.approx(turn % 360)
        assert b[2] == pytest.approx(a[2], abs=1e-12)
        assert (turned.object_length, turned.object_thickness, turned.digits, turned.mu, turned.options) == \
            (scene.object_length, scene.object_thickness, scene.digits, scene.mu, scene.options)


def test_a_world_row_merged_into_a_table_without_it_stands_in_its_object_s_block(tmp_path, monkeypatch):
    """--merge of a world the table lacks puts its row among its object's worlds, in WORLDS' order,
    not after the rows of later groups."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    old = results.load("campaigns")
    order = [r["key"] for r in old["rows"]]
    missing = next(r for r in old["rows"] if r["subject"] == "guitar_pick, friction x1.3")
    assert any(r["campaign"].startswith("unaimed") for r in old["rows"])  # a later group to land after
    table = tmp_path / "t.md"
    table.write_text((ROOT / "docs/results/campaigns.md").read_text())
    (tmp_path / "t.json").write_text(json.dumps({**old, "rows": [r for r in old["rows"] if r is not missing]}))
    footer = "12 s in all; " + table.read_text().strip().splitlines()[-1].split(" s in all; ", 1)[1]
    monkeypatch.setattr(campaigns, "WORLD_LABELS", ("friction x1.3",))
    merged, _, _, _ = campaigns.merge_rows(table, [campaigns.Row.from_record(missing)], footer, {"worlds"})
    assert [r["key"] for r in merged] == order


def test_pairing_again_sets_drake_s_rows_beside_mujoco_s_rows_as_they_are_now(tmp_path, monkeypatch):
    """sim_campaigns --pair: a Drake file whose MuJoCo rows are stale (another count, another p)
    gets MuJoCo's rows as its MuJoCo file has them and the Fisher test of the two counts again,
    and keeps its own rows' figures; no trial runs."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    doc = results.load("campaigns_drake_tangram")
    stale = json.loads(json.dumps(doc))
    row = stale["rows"][0]
    row["mujoco"]["successes"] = row["mujoco"]["successes"] - 1
    row["fisher_p"] = 0.5
    path = tmp_path / "drake.json"
    path.write_text(json.dumps(stale))
    monkeypatch.setattr(sys, "argv", ["sim_campaigns.py", "--pair", str(path)])
    campaigns.pair_again(path)
    again = json.loads(path.read_text())
    mujoco = {r["key"]: r for r in results.load("campaigns_tangram")["rows"]}
    for r, before in zip(again["rows"], doc["rows"]):
        m = mujoco[r["key"]]
        assert r["mujoco"] == {k: m[k] for k in r["mujoco"]}
        assert r["fisher_p"] == pytest.approx(_fisher_two_sided(r["successes"], r["trials"], m["successes"],
                                                                m["trials"]), rel=1e-9)
        assert {k: v for k, v in r.items() if k not in ENGINE_KEYS} == {k: v for k, v in before.items()
                                                                        if k not in ENGINE_KEYS}
    assert again["paired"]["command"].endswith(f"--pair {path}")


def test_pairing_again_keeps_the_mujoco_file_a_drake_run_was_set_beside(tmp_path, monkeypatch):
    """sim_campaigns --pair on a Drake file set beside a MuJoCo file other than the one its rows
    would choose today (the base rows from the previous starts, beside
    campaigns_previous_starts.json): it is paired again with that same file's rows."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    doc = results.load("campaigns_drake")
    assert doc["mujoco_source"] == "docs/results/campaigns_previous_starts.json"
    path = tmp_path / "drake.json"
    path.write_text(json.dumps(doc))
    monkeypatch.setattr(sys, "argv", ["sim_campaigns.py", "--pair", str(path)])
    campaigns.pair_again(path)
    again = json.loads(path.read_text())
    assert again["mujoco_source"] == doc["mujoco_source"]
    mujoco = {r["key"]: r for r in results.load("campaigns_previous_starts")["rows"]}
    for r in again["rows"]:
        m = mujoco.get(r["key"])
        assert r["mujoco"] == (None if m is None else {k: m[k] for k in r["mujoco"]}), r["key"]


def test_a_table_of_two_campaign_files_shows_both_files_rows_in_order():
    """SOURCE+SOURCE:objects (and :single, :worlds) joins the row groups two runs of the same code
    wrote apart: its rows are the first file's table's, then the second's."""
    first, second = "campaigns_middle_aim", "campaigns_middle_aim_rows"
    for name in ("objects", "single"):
        both = _rows(results.table(f"{first}+{second}:{name}"))
        assert both == _rows(results.table(f"{first}:{name}")) + _rows(results.table(f"{second}:{name}"))
        assert len(both) > len(_rows(results.table(f"{first}:{name}")))


@pytest.mark.parametrize("campaign, studies", [
    ("campaigns_drake_middle_aim", {"guitar_pick": "middle-aim-base", "puzzle_piece": "middle-aim-base"}),
    ("campaigns_drake_0.025ms", {"guitar_pick": "table-step-pick", "puzzle_piece": "table-step-puzzle",
                                 "fabric_chalk": "table-step-chalk"})])
def test_the_contacts_study_runs_the_drake_campaign_s_own_trials(campaign, studies):
    """The trials of the base rows run again with their forces logged are the campaign's: as many of
    each object's fail in Drake, at the campaign's step, as its campaign row lost of the same seed's
    trials (at 0.1 ms and at Drake's step, record 0126); and in MuJoCo, where the study ran there
    too, as MuJoCo's row set beside it."""
    rows = results.load("campaigns_drake_contacts")["rows"]
    campaign_rows = {r["key"]: r for r in results.load(campaign)["rows"]}
    for name, study in studies.items():
        row = campaign_rows[f"base-{name}-rounded-tip"]
        trials = [r for r in rows if r["study"] == study and r.get("object") == name and "trial" in r]
        drake = [r for r in trials if r["engine"].startswith("drake")]
        assert len(drake) == row["trials"]
        assert sum(r["outcome"] != "success" for r in drake) == row["trials"] - row["successes"]
        mujoco = [r for r in trials if r["engine"] == "mujoco"]
        assert sum(r["outcome"] == "success" for r in mujoco) == len(mujoco)  # MuJoCo's row placed all of its 40
        assert row["mujoco"]["successes"] == row["mujoco"]["trials"]


def test_the_fifth_friction_study_runs_the_drake_control_s_own_trials():
    """The control's 20 trials (a fifth of the friction) run again at Drake's step with their forces
    logged are the control row's: as many place in Drake as the row placed, and as many leave the
    plane as the row's failures say did; none places in MuJoCo, as none of MuJoCo's 40 did."""
    row = next(r for r in results.load("campaigns_drake_0.025ms_rows")["rows"]
               if r["key"] == "control-pick-a-fifth-of-the-friction")
    trials = [r for r in results.load("campaigns_drake_contacts")["rows"]
              if r["study"] == "fifth-friction-at-step" and "trial" in r]
    drake = [r for r in trials if r["engine"] == "drake"]
    assert len(drake) == row["trials"]
    assert sum(r["outcome"] == "success" for r in drake) == row["successes"]
    left = sum(n for n, cause in row["failures"] if cause.startswith("object left the plane"))
    assert sum(r["outcome"] == "object left the plane" for r in drake) == left
    assert not any(r["outcome"] == "success" for r in trials if r["engine"] == "mujoco")
    assert row["mujoco"]["successes"] == 0


def test_drake_s_step_is_what_record_0126_s_rule_reads_off_the_study():
    """tools/drake_step.py's file holds what its rule makes of the contacts study's trial rows as
    they are now, with its own drops: every row, the chosen step among them, comes back the same."""
    import sys

    from ungrasp_ompl.sim import drake_trial

    sys.path.insert(0, str(ROOT / "tools"))
    drake_step = importlib.import_module("drake_step")
    kept = [r for r in results.load("drake_step")["rows"] if not r["label"].startswith("study: ")]
    dropped: dict[float, list[dict]] = {}
    for r in kept:
        if r["label"].startswith("drop: "):
            dropped.setdefault(r["step_ms"], []).append({k: v for k, v in r.items() if k not in ("key", "study")})
    made = drake_step.step_rows(results.load("campaigns_drake_contacts")["rows"], dropped)
    assert [{k: v for k, v in r.items() if k not in ("key", "study")} for r in kept] == made
    assert made[-1]["chosen_step_ms"] * 1e-3 == pytest.approx(drake_trial.DRAKE_TIME_STEP, rel=1e-12)


def test_the_landing_map_is_what_the_model_of_the_fall_gives_over_the_goal_states():
    """tools/landing_map.py's file holds what the model gives now: the puzzle piece's rows made again
    (its plan's release were it to end anywhere in the goal region, the least-moving goal state the
    start reaches and over the region, the counts) come back the same; for every object the
    least-moving goal state the start reaches lands no farther than that release, itself such a
    state."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    landing_map = importlib.import_module("landing_map")
    kept = [r for r in results.load("landing_map")["rows"]  # the current map; earlier ones are kept as studies
            if r.get("study") == "landing-map" and not r["label"].startswith("study: ")]
    made, _ = landing_map.mapped("puzzle_piece")
    mine = [{k: v for k, v in r.items() if k not in ("key", "study")} for r in kept if r["object"] == "puzzle_piece"]
    assert mine == made
    for name in ("guitar_pick", "puzzle_piece", "fabric_chalk"):
        rows = {r["label"].split(": ", 1)[1]: r for r in kept if r["object"] == name}
        assert rows["the least-moving goal state the start reaches"]["farthest_mm"] <= \
            rows["the release anywhere in the goal region"]["farthest_mm"] + 1e-9
        assert rows["the least-moving goal state"]["farthest_mm"] <= \
            rows["the least-moving goal state the start reaches"]["farthest_mm"] + 1e-9


def test_the_contacts_studys_summaries_are_those_of_its_trials(tmp_path, monkeypatch):
    """Every summary per object and engine in the contacts study's file is what sim_campaigns'
    summaries make of that study's trial rows: made again (--contacts-summaries) on a copy of the
    file, every row comes back the same, in the same order."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    doc = results.load("campaigns_drake_contacts")
    assert any("trials" in r for r in doc["rows"])
    (tmp_path / "docs" / "results").mkdir(parents=True)
    path = tmp_path / "docs" / "results" / "campaigns_drake_contacts.json"
    path.write_text(json.dumps(doc))
    monkeypatch.setattr(campaigns, "ROOT", tmp_path)
    campaigns.contact_summaries()
    again = json.loads(path.read_text())
    assert again["rows"] == doc["rows"]


def test_a_merged_run_of_one_object_keeps_the_others_rows_and_the_runs_that_made_them(tmp_path, monkeypatch):
    """--objects with --merge replaces the rows of the objects it ran and the groups' totals, and
    keeps the other objects' rows as they were, listed under the runs that made them; the rows it
    counts in a total without running them (kept) are not the new run's."""
    import sys

    sys.path.insert(0, str(ROOT / "tools"))
    campaigns = importlib.import_module("sim_campaigns")
    old = results.load("campaigns_least_moving_scenes")
    table = tmp_path / "t.md"
    table.write_text((ROOT / "docs/results/campaigns_least_moving_scenes.md").read_text())
    (tmp_path / "t.json").write_text(json.dumps(old))
    base = [r for r in old["rows"] if r["campaign"] == "base"]
    puzzle = next(r for r in base if r["object"] == "puzzle_piece")
    again = dataclasses.replace(campaigns.Row.from_record(puzzle), successes=puzzle["successes"] - 1)
    kept = [dataclasses.replace(campaigns.Row.from_record(r), kept=True) for r in base
            if r["object"] in ("guitar_pick", "fabric_chalk")]
    total = campaigns.Row("base: the three objects", sum(r.successes for r in [again, *kept]), 120, 120, "-", "-",
                          "109/120", (109, 120), "secure", "-")
    footer = "12 s in all; " + table.read_text().strip().splitlines()[-1].split(" s in all; ", 1)[1]
    monkeypatch.setattr(campaigns, "SELECTED", ("puzzle_piece",))
    merged, runs, _, _ = campaigns.merge_rows(table, [again, *kept, total], footer, {"base"})
    by_key = {r["key"]: r for r in merged}
    assert by_key[puzzle["key"]]["successes"] == puzzle["successes"] - 1
    assert by_key["base-the-three-objects"]["successes"] == sum(r["successes"] for r in base[:3]) - 1
    assert [k for k in by_key if k not in {r["key"] for r in old["rows"]}] == []
    others = [r for r in old["rows"] if r["key"] not in (puzzle["key"], "base-the-three-objects")]
    assert all(by_key[r["key"]] == results.parse_row(results.row_line(r)) for r in others)
    assert runs["base: puzzle_piece"]["rows"] == [puzzle["key"], "base-the-three-objects"]
    first = next(run for name, run in runs.items() if name != "base: puzzle_piece")
    assert {r["key"] for r in others} <= set(first["rows"])
