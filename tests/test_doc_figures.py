"""The figures the pages quote come from the results files the tools write (docs/results/), so that
no two pages can disagree: every marked figure and table of README.md and docs/results.md is what
tools/campaign_results.py builds from its file, the JSON of a campaign holds its table's figures,
no count stands on a page outside a mark, and the README's first example is what its command prints."""

from __future__ import annotations

import importlib.util
import json
import re

import pytest

from conftest import ROOT, run_cli

PAGES = ("README.md", "docs/results.md")
#: The campaign tables tools/sim_campaigns.py wrote, each with its JSON beside it.
TABLES = ("campaigns", "campaigns_previous_grip_rule")


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
    assert doc["rows"] == parsed["rows"]
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
    assert totals
    for k in totals:
        three = rows[k - 3:k]
        assert [r["object"] for r in three] == list(results.OBJECTS)
        assert rows[k]["successes"] == sum(r["successes"] for r in three)
        assert rows[k]["trials"] == sum(r["trials"] for r in three)
        assert rows[k]["placed"] == sum(r["placed"] for r in three)


@pytest.mark.parametrize("page", PAGES)
def test_every_marked_figure_is_its_results_file_s(page):
    text = (ROOT / page).read_text()
    assert len(results.FIG.findall(text)) >= 2 and len(results.TABLE.findall(text)) >= 2, page
    assert results.differences(text) == []


def test_a_figure_that_differs_from_its_file_is_found():
    """The check finds a changed figure, in a table and in a sentence, and a row the file lacks."""
    text = (ROOT / "docs" / "results.md").read_text()
    table = results.TABLE.search(text)
    changed = text.replace(table.group(3), table.group(3).replace("119/120", "118/120", 1), 1)
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
