"""The results files as data, and the figures the documentation quotes from them.

    python tools/campaign_results.py --from-markdown docs/results/campaigns.md [--command CMD] [--produced DATE]
    python tools/campaign_results.py --render README.md docs/results.md
    python tools/campaign_results.py --check README.md docs/results.md
    python tools/campaign_results.py --study-markdown landing_check world_failures

`tools/sim_campaigns.py --table FILE.md` writes its markdown table and, beside it, FILE.json: the
same rows as numbers (success count, trials, the Wilson 95 % interval, the count placed by the
paper's criterion, the placement errors, the deepest sinking, the failures by cause), with the
command that ran and the day. `--from-markdown` reads a table the tool wrote into that JSON without
running anything; the day is that of the last commit of the table (git) unless --produced gives it.

A page quotes a results file through marks that `--render` fills in and `--check` (and
tests/test_doc_figures.py) compares:

* `<!-- fig SOURCE:ROW:FIELD -->...<!-- /fig -->` one figure: SOURCE a file of docs/results/
  without its extension, ROW a row's key (its label in lower case, every run of other characters
  than letters, digits, `_`, `.` and `+` made one `-`), FIELD one of FIELDS; a summary.json of
  `simulate` (one row) and the whole file's own fields (`produced`, `command`, `reruns`: the runs
  merged into it after the first, `rerun-K`: the K-th of them) take no ROW;
* `<!-- table SOURCE:NAME -->` ... `<!-- /table -->` a table built from the file (TABLES;
  `grip_rule` compares two: `SOURCE+SOURCE:grip_rule`; `steps` any number, each run at one step;
  `objects`, `single`, `worlds` and `readme_worlds` of several files show their rows joined, the
  row groups of one code run apart; `readme` takes a row a file lacks from the next that has it).

A study's results file (`tools/landing_check.py --results`, `tools/world_failures.py --results`)
holds rows of its own fields, with the key of their label, and `formats`: how each field is shown
(a Python format; a list shows its least and largest, "a..b"). Each study it holds has a row
"study: NAME" with its command, its wall time (`seconds`, `minutes`) and its day; a tool writes one
study's rows into the file with `merge_study`, keeping the others', and the markdown beside it is
rendered from the JSON (`study_markdown`). FIELD is then any field of the row.

So a page cannot state a figure its results file does not hold, and a new campaign changes the
pages by `--render`.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
OBJECT_NAMES = {"guitar_pick": "guitar pick", "puzzle_piece": "puzzle piece", "fabric_chalk": "fabric chalk"}
#: A world holds an object's result where at least this share of its trials succeed with a mean
#: placement error below HOLDS_ERROR_MM: 38 of 40, and the paper's mean error.
HOLDS_SHARE = 0.95
HOLDS_ERROR_MM = 2.6
#: The footer's friction clause where the table was written before worlds fixed their friction
#: (docs/decisions/0100): a world's friction factor then compounded with the drawn friction error.
COMPOUNDED = "a world's friction compounded with the drawn friction error"


# --- the table sim_campaigns writes, read back --------------------------------------------------

def row_key(label: str) -> str:
    """A row's key: its label in lower case, every run of other characters than letters, digits,
    `_`, `.` and `+` made one `-`."""
    return re.sub(r"[^a-z0-9_.+]+", "-", label.lower()).strip("-")


def split_label(label: str) -> tuple[str, str]:
    """A label's campaign and subject: the text before and after its last `: ` outside brackets
    ("unaimed (landing: planned): guitar_pick, rounded tip" -> "unaimed (landing: planned)",
    "guitar_pick, rounded tip"); a label without one is its own campaign, with no subject."""
    depth, cut = 0, -1
    for k, ch in enumerate(label):
        depth += ch == "("
        depth -= ch == ")"
        if depth == 0 and label.startswith(": ", k):
            cut = k
    return (label, "") if cut < 0 else (label[:cut], label[cut + 2:])


def subject_object(subject: str) -> str | None:
    """The shipped object a row's subject names first, or None."""
    first = re.split(r"[ ,(]", subject, maxsplit=1)[0]
    return first if first in OBJECTS else None


def _number(text: str) -> float | None:
    return None if text.strip() == "-" else float(text)


def parse_row(line: str) -> dict:
    """One row of the table (sim_campaigns.Row.line) as a record."""
    cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
    if len(cells) != 8:
        raise ValueError(f"a campaign row has 8 cells, this one {len(cells)}: {line}")
    label, ours, placed, errors, paper, model, failures, sinking = cells
    m = re.fullmatch(r"(\d+)/(\d+) \((\d+)-(\d+) %\)", ours)
    p = re.fullmatch(r"(\d+)/(\d+) \((?:mean ([\d.]+) mm|-)\)", placed)
    if m is None or p is None or p.group(2) != m.group(2):
        raise ValueError(f"unreadable counts in: {line}")
    mean, largest = (None, None) if errors == "-" else (float(x) for x in errors.split(" / "))
    causes = []
    if failures != "-":
        for part in failures.split("; "):
            c = re.fullmatch(r"(\d+) (.+)", part)
            causes.append([int(c.group(1)), c.group(2)] if c else [None, part])
    campaign, subject = split_label(label)
    return {"key": row_key(label), "label": label, "campaign": campaign, "subject": subject,
            "object": subject_object(subject), "successes": int(m.group(1)), "trials": int(m.group(2)),
            "interval_percent": [int(m.group(3)), int(m.group(4))], "placed": int(p.group(1)),
            "placed_error_mean_mm": None if p.group(3) is None else float(p.group(3)),
            "error_mean_mm": mean, "error_max_mm": largest, "paper": paper, "model": model,
            "failures": causes, "sinking_max_mm": _number(sinking)}


def row_line(r: dict) -> str:
    """The record's row as the tool writes it (the inverse of parse_row)."""
    placed = "-" if r["placed_error_mean_mm"] is None else f"mean {r['placed_error_mean_mm']:.2f} mm"
    errors = "-" if r["error_mean_mm"] is None else f"{r['error_mean_mm']:.2f} / {r['error_max_mm']:.2f}"
    failures = "; ".join(text if n is None else f"{n} {text}" for n, text in r["failures"]) or "-"
    sinking = "-" if r["sinking_max_mm"] is None else f"{r['sinking_max_mm']:.3f}"
    lo, hi = r["interval_percent"]
    return (f"| {r['label']} | {r['successes']}/{r['trials']} ({lo}-{hi} %) | {r['placed']}/{r['trials']} ({placed}) | "
            f"{errors} | {r['paper']} | {r['model']} | {failures} | {sinking} |")


def parse_footer(footer: str) -> dict:
    """The table's last line: "2785 s in all; 40 trials per row, seed 1, 2 jobs, STEP, RULE[, FRICTION]"."""
    m = re.fullmatch(r"(\d+) s in all; (\d+) trials per row, seed (\d+), (\d+) jobs, (.+)", footer.strip())
    if m is None:
        raise ValueError(f"unreadable footer: {footer}")
    parts = m.group(5).split(", ", 2)
    return {"seconds": int(m.group(1)), "trials_per_row": int(m.group(2)), "seed": int(m.group(3)),
            "jobs": int(m.group(4)), "step": parts[0], "grip_rule": parts[1],
            "world_friction": parts[2] if len(parts) > 2 else COMPOUNDED}


def parse_table(text: str) -> dict:
    """The markdown a campaign wrote (header, rows, a blank line, the footer) as records."""
    lines = [line for line in text.splitlines() if line.strip()]
    rows = [parse_row(line) for line in lines[2:] if line.startswith("| ")]
    footer = [line for line in lines[2:] if not line.startswith("| ")]
    if len(footer) != 1:
        raise ValueError("a campaign table ends in one footer line")
    return {**parse_footer(footer[0]), "rows": rows}


def last_commit_day(path: Path) -> str:
    """The day (YYYY-MM-DD) of the last commit that touched path."""
    day = subprocess.run(["git", "log", "-1", "--format=%cs", "--", str(path)], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    if not day:
        raise SystemExit(f"{path}: no commit holds it; give the day with --produced")
    return day


def table_json(table: Path, command: str, produced: str) -> dict:
    """The results file of a campaign table: where it is, the command that wrote it, the day, the
    environment it was written in (ungrasp_ompl.provenance), its rows."""
    from ungrasp_ompl.provenance import environment

    rel = table.resolve().relative_to(ROOT) if table.resolve().is_relative_to(ROOT) else table
    return {"table": str(rel), "command": command, "produced": produced, "environment": environment(),
            **parse_table(table.read_text())}


def write_json(table: Path, command: str, produced: str | None = None) -> Path:
    """Write TABLE.json beside the markdown table; produced defaults to today."""
    from ungrasp_ompl.io import write_text_atomic

    path = table.with_suffix(".json")
    doc = table_json(table, command, produced or date.today().isoformat())
    write_text_atomic(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    return path


# --- figures -----------------------------------------------------------------------------------

def load(source: str) -> dict:
    """docs/results/SOURCE.json; a summary.json of `simulate` gets the day of its last commit."""
    path = RESULTS / f"{source}.json"
    doc = json.loads(path.read_text())
    if "rows" not in doc and "produced" not in doc:
        doc = {**doc, "produced": last_commit_day(path)}
    return doc


def _rate(successes: int, trials: int) -> str:
    from ungrasp_ompl.sim.campaign import wilson_interval

    lo, hi = wilson_interval(successes, trials)
    return f"{successes}/{trials} ({100 * lo:.0f}-{100 * hi:.0f} %)"


def _mm(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f} mm"


def _failures(causes) -> str:
    return "; ".join(text if n is None else f"{n} {text}" for n, text in causes) or "-"


def summary_row(doc: dict) -> dict:
    """A summary.json of `simulate` as a campaign row's record."""
    from ungrasp_ompl.sim.campaign import wilson_interval

    err, placed = doc["position_error_mm"], doc["placed_position_error_mm"]
    lo, hi = wilson_interval(doc["successes"], doc["trials"])
    aim = doc.get("aim_m")
    return {"successes": doc["successes"], "trials": doc["trials"], "interval_percent": [round(100 * lo), round(100 * hi)],
            "placed": doc["placed_paper_criterion"], "placed_error_mean_mm": placed["mean"],
            "error_mean_mm": err["mean"], "error_max_mm": err["max"], "sinking_max_mm": doc["max_penetration_mm"],
            "failures": [[n, c] for c, n in doc["causes"].items()],
            "aim_mm": None if aim is None else 1000 * sum(x * x for x in aim) ** 0.5}


#: What a figure shows of a row.
FIELDS = {
    "strict": lambda r: f"{r['successes']}/{r['trials']}",
    "interval": lambda r: "{}-{} %".format(*r["interval_percent"]),
    "strict_interval": lambda r: "{}/{} ({}-{} %)".format(r["successes"], r["trials"], *r["interval_percent"]),
    "placed": lambda r: f"{r['placed']}/{r['trials']}",
    "error_mean": lambda r: _mm(r["error_mean_mm"]),
    "error_max": lambda r: _mm(r["error_max_mm"]),
    "placed_error_mean": lambda r: _mm(r["placed_error_mean_mm"]),
    "sinking": lambda r: _mm(r["sinking_max_mm"], 3),
    "failures": lambda r: _failures(r["failures"]),
    "paper": lambda r: r["paper"],
    "aim": lambda r: _mm(r["aim_mm"]),
    # a row of the engines' comparison (sim_campaigns.py --engine drake): MuJoCo's row of the same key
    "mujoco_strict_interval": lambda r: FIELDS["strict_interval"](r["mujoco"]),
    "mujoco_error_mean": lambda r: _mm(r["mujoco"]["error_mean_mm"]),
    "fisher_p": lambda r: _p(r["fisher_p"]),
}
#: What a figure shows of a whole file.
FILE_FIELDS = {"produced": lambda d: d["produced"], "command": lambda d: f"`{d['command']}`",
               "seconds": lambda d: f"{d['seconds']} s", "trials_per_row": lambda d: str(d["trials_per_row"]),
               "reruns": lambda d: "; ".join(_rerun(r) for r in _reruns(d))}


def _reruns(doc: dict) -> list[dict]:
    """The runs merged into a campaign file after its first, in the order they ran."""
    return [r for r in doc.get("runs", {}).values() if r["command"] != doc["command"]]


def _rerun(run: dict) -> str:
    """A run as pages quote it: its command, its wall time and how many rows it made."""
    return f"`{run['command']}` ({run['seconds']} s, {len(run['rows'])} rows)"


def show(value, form: str = "{}") -> str:
    """A study row's value as its file's format shows it: "-" for none, a word as it is, a list of
    numbers as its least and largest ("a..b", one where they agree); a zero never signed "-"."""
    def number(x: float) -> str:
        text = form.format(x)
        return form.format(0.0) if text.startswith("-") and float(text) == 0 else text

    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, list):
        if value and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            lo, hi = number(min(value)), number(max(value))
            return lo if lo == hi else f"{lo}..{hi}"
        return "; ".join(" ".join(str(x) for x in v) if isinstance(v, list) else show(v, form) for v in value)
    return number(value)


def figure(spec: str, cache: dict | None = None) -> str:
    """The text of the figure SOURCE:ROW:FIELD (or SOURCE:FIELD for a file's own field, or a
    summary.json's)."""
    cache = {} if cache is None else cache
    parts = spec.split(":")
    source = parts[0]
    if source not in cache:
        cache[source] = load(source)
    doc = cache[source]
    if len(parts) == 2 and parts[1] in FILE_FIELDS:
        return FILE_FIELDS[parts[1]](doc)
    if len(parts) == 2 and re.fullmatch(r"rerun-[1-9]\d*", parts[1]):  # one merged run, from 1
        runs = _reruns(doc)
        k = int(parts[1].split("-")[1])
        if k > len(runs):
            raise KeyError(f"figure {spec!r}: {source} holds {len(runs)} runs after its first")
        return _rerun(runs[k - 1])
    if len(parts) == 2 and "rows" not in doc:
        return FIELDS[parts[1]](summary_row(doc))
    if len(parts) != 3:
        raise KeyError(f"figure {spec!r}: SOURCE:ROW:FIELD")
    rows = {r["key"]: r for r in doc["rows"]}
    if parts[1] not in rows:
        raise KeyError(f"figure {spec!r}: no row {parts[1]!r} in {source}")
    if "formats" in doc:  # a study's file: any field of the row, as the file shows it
        if parts[2] not in rows[parts[1]]:
            raise KeyError(f"figure {spec!r}: row {parts[1]!r} of {source} has no field {parts[2]!r}")
        return show(rows[parts[1]][parts[2]], doc["formats"].get(parts[2], "{}"))
    return FIELDS[parts[2]](rows[parts[1]])


# --- tables ------------------------------------------------------------------------------------

def object_groups(doc: dict) -> dict[str, dict[str, dict]]:
    """The campaigns with a row for each of the three objects, in the table's order: campaign ->
    object -> row (the worlds apart)."""
    groups: dict[str, dict[str, dict]] = {}
    for r in doc["rows"]:
        if r["object"] is not None and r["campaign"] != "world":
            groups.setdefault(r["campaign"], {})[r["object"]] = r
    return {c: g for c, g in groups.items() if set(g) == set(OBJECTS)}


def totals(doc: dict) -> dict[str, dict]:
    """The rows over the three objects the tool wrote: the campaign of the three rows before each -> row."""
    out, rows = {}, doc["rows"]
    for k, r in enumerate(rows):
        if r["subject"] == "the three objects" and k >= 3:
            out[rows[k - 1]["campaign"]] = r
    return out


def worlds(doc: dict) -> dict[str, dict[str, dict]]:
    """World label -> object -> row; "as modelled" from the base rows first, where the file has them."""
    base = object_groups(doc).get("base")
    out = {} if base is None else {"as modelled": base}
    for r in doc["rows"]:
        if r["campaign"] == "world":
            out.setdefault(r["subject"].split(", ", 1)[1], {})[r["object"]] = r
    return out


def holds(row: dict) -> bool:
    """Whether a world holds an object's result (HOLDS_SHARE, HOLDS_ERROR_MM)."""
    return (row["successes"] >= HOLDS_SHARE * row["trials"] and row["error_mean_mm"] is not None
            and row["error_mean_mm"] < HOLDS_ERROR_MM)


def _held(group: dict[str, dict]) -> str:
    held = [OBJECT_NAMES[o] for o in OBJECTS if holds(group[o])]
    return "all three" if len(held) == 3 else ", ".join(held) or "none"


def _world_label(doc: dict, label: str) -> str:
    """A world's label, with the friction it ran at where the drawn error compounded with its factor."""
    m = re.fullmatch(r"friction x([\d.]+)", label)
    if m is None or doc["world_friction"] != COMPOUNDED:
        return label
    from ungrasp_ompl.scene.perturbation import PRESETS

    f = float(m.group(1))
    return f"{label}, the drawn error on top: x{f * (1 - PRESETS['paper'].friction):.2f}-{f:.2f}"


def _sum(group: dict[str, dict]) -> tuple[int, int]:
    return sum(group[o]["successes"] for o in OBJECTS), sum(group[o]["trials"] for o in OBJECTS)


def table_objects(doc: dict) -> str:
    """Each campaign with a row per object: strict successes per object, over the three with its
    interval, and the paper's figure."""
    lines = ["| campaign | guitar pick | puzzle piece | fabric chalk | the three objects (95 % interval) | the paper |",
             "|---|---|---|---|---|---|"]
    total = totals(doc)
    for campaign, group in object_groups(doc).items():
        paper = total[campaign]["paper"] if campaign in total else group[OBJECTS[0]]["paper"]
        cells = " | ".join(FIELDS["strict"](group[o]) for o in OBJECTS)
        lines.append(f"| {campaign} | {cells} | {_rate(*_sum(group))} | {paper} |")
    return "\n".join(lines)


def table_single(doc: dict) -> str:
    """The rows that are neither an object's of a campaign over the three, nor a world's, nor a total."""
    lines = ["| campaign | ours (95 % interval) | placed by the paper's criterion | the paper | the model on the plan "
             "| failures |", "|---|---|---|---|---|---|"]
    grouped = {r["key"] for g in object_groups(doc).values() for r in g.values()}
    for r in doc["rows"]:
        if r["key"] in grouped or r["campaign"] == "world" or r["subject"] == "the three objects":
            continue
        lines.append(f"| {r['label']} | {FIELDS['strict_interval'](r)} | {FIELDS['placed'](r)} | {r['paper']} | "
                     f"{r['model']} | {FIELDS['failures'](r)} |")
    return "\n".join(lines)


def table_worlds(doc: dict) -> str:
    """Per world and object: strict successes and the mean error of the successes; where it holds."""
    names = " | ".join(OBJECT_NAMES[o] for o in OBJECTS)
    lines = [f"| world the trials run in | {names} | holds for |", "|---|---|---|---|---|"]
    for label, group in worlds(doc).items():
        cells = " | ".join(FIELDS["strict"](group[o]) + ("" if group[o]["error_mean_mm"] is None
                                                           else f", {_mm(group[o]['error_mean_mm'])}")
                           for o in OBJECTS)
        lines.append(f"| {_world_label(doc, label)} | {cells} | {_held(group)} |")
    return "\n".join(lines)


def table_readme_worlds(doc: dict) -> str:
    """The README's worlds: per world and object the strict successes, where it holds."""
    names = " | ".join(OBJECT_NAMES[o] for o in OBJECTS)
    lines = [f"| world the trials run in | {names} | holds for |", "|---|---|---|---|---|"]
    for label, group in worlds(doc).items():
        cells = " | ".join(FIELDS["strict"](group[o]) for o in OBJECTS)
        lines.append(f"| {_world_label(doc, label)} | {cells} | {_held(group)} |")
    return "\n".join(lines)


def table_readme(doc: dict, *older: dict) -> str:
    """The README's comparison with the paper: the base rows, the flat tip, caging and the tangram;
    a row doc lacks is taken from the first of older that has it, its step named where it is not doc's."""
    def source(has) -> tuple[dict, str]:
        for d in (doc, *older):
            if has(d):
                return d, "" if d.get("step") == doc.get("step") else f" ({d['step']})"
        raise KeyError("no results file has the row")

    lines = ["| experiment | ours, simulated: successes (95 % interval) | the paper, on the robot |", "|---|---|---|"]
    d, step = source(lambda d: "base" in object_groups(d))
    lines.append(f"| the three objects, 40 trials each{step} | {_rate(*_sum(object_groups(d)['base']))} | "
                 f"{totals(d)['base']['paper']} |")
    d, step = source(lambda d: "edge" in object_groups(d))
    edge = object_groups(d)["edge"]
    lines.append(f"| the same, a flat finger tip (edge contact){step} | {_rate(*_sum(edge))} | {edge[OBJECTS[0]]['paper']} |")
    d, step = source(lambda d: any(r["campaign"] == "caging" for r in d["rows"]))
    for r in (r for r in d["rows"] if r["campaign"] == "caging"):
        tip = r["subject"].rsplit(", ", 1)[1]
        lines.append(f"| the pick started outside force closure, {tip}{step} | {FIELDS['strict_interval'](r)} | "
                     f"{r['paper']} |")
    d, step = source(lambda d: any(r["key"] == "tangram-rounded-tip-lattice-plans" for r in d["rows"]))
    tangram = next(r for r in d["rows"] if r["key"] == "tangram-rounded-tip-lattice-plans")
    lines.append(f"| the tangram, whole layouts{step} | {FIELDS['strict_interval'](tangram)} | {tangram['paper']} |")
    return "\n".join(lines)


def table_grip_rule(doc: dict, previous: dict) -> str:
    """The base rows judged by the lost-grip bound and by the previous rule, the same trials."""
    now, before = object_groups(doc)["base"], object_groups(previous)["base"]
    lines = ["| object | the lost-grip bound | the previous rule |", "|---|---|---|"]
    for o in OBJECTS:
        lines.append(f"| {OBJECT_NAMES[o]} | {FIELDS['strict'](now[o])} | {FIELDS['strict'](before[o])} |")
    lines.append(f"| the three objects | {_rate(*_sum(now))} | {_rate(*_sum(before))} |")
    return "\n".join(lines)


def _study(doc: dict, study: str) -> list[dict]:
    """A study's rows of a study's results file, its own row aside."""
    return [r for r in doc["rows"] if r.get("study") == study and not r["label"].startswith("study: ")]


def _f(doc: dict, row: dict, field: str) -> str:
    """One field of a study's row as its file shows it."""
    return show(row.get(field), doc["formats"].get(field, "{}"))


#: The release model's target: its landing within this of the simulated one (mm).
LANDING_TARGET_MM = 0.5


def table_landing(doc: dict) -> str:
    """The release model's landings against the simulated ones (tools/landing_check.py), per plan
    and world (mm along GB; bold: a model - simulated beyond LANDING_TARGET_MM): the RRT* plans of
    the cost objective from the studies' starts, then those planned without the scenes' landing
    spread bound, then those without P_dpsi, where the file has them."""
    return _landing_table(doc, (("landing", "RRT*"), ("landing, no spread bound", "RRT*, no spread bound"),
                                ("landing, no P_dpsi", "no P_dpsi")))


def table_landing_scenes(doc: dict) -> str:
    """table_landing of the plans the campaign runs, from the scenes' own starts and under their own
    objective (tools/landing_check.py --scene-starts)."""
    return _landing_table(doc, (("record-0121-starts", "the scene's plan"),), kept=True)


def _landing_table(doc: dict, studies: tuple[tuple[str, str], ...], kept: bool = False) -> str:
    """The landing table of the studies given, each as (study, how its plans are named); kept: with
    a last column, the model's mean with the scene's robot.landing_offset less the simulated mean."""
    lines = ["| plan | world | planned | model | simulated (along / across) | model - simulated "
             "| model mean / simulated mean (n) |" + (" with the offset - simulated mean |" if kept else ""),
             "|---|---|---|---|---|---|---|" + ("---|" if kept else "")]
    for study, plan in studies:
        first = None
        for r in _study(doc, study):
            if "world" not in r:
                continue
            name = f"{OBJECT_NAMES[r['object']]}, {plan}"
            if r["sim_placed"]:
                simulated = f"{_f(doc, r, 'sim_along_mm')} / {_f(doc, r, 'sim_across_mm')}"
                diff = _f(doc, r, "model_minus_sim_mm")
                if min(abs(d) for d in r["model_minus_sim_mm"]) > LANDING_TARGET_MM:
                    diff = f"**{diff}**"
            else:
                simulated, diff = r["sim_outcome"].replace("_", " "), ""
            means = "" if r["n"] == 0 else f"{_f(doc, r, 'model_mean_mm')} / {_f(doc, r, 'sim_mean_mm')} ({r['n']})"
            lines.append(f"| {'' if name == first else name} | {r['world']} | {_f(doc, r, 'planned_mm')} | "
                         f"{_f(doc, r, 'model_mm')} | {simulated} | {diff} | {means} |"
                         + (f" {_kept_diff(doc, r)} |" if kept else ""))
            first = name
    return "\n".join(lines)


def _kept_diff(doc: dict, r: dict) -> str:
    """The model's mean with the scene's offset less the simulated mean (mm), bold past the target."""
    if r.get("mean_kept_minus_sim_mm") is None:
        return ""
    text = _f(doc, r, "mean_kept_minus_sim_mm")
    return f"**{text}**" if abs(r["mean_kept_minus_sim_mm"]) > LANDING_TARGET_MM else text


def _leg(name: str) -> str:
    return "the press" if name == "press" else name


def table_wf_trials(doc: dict) -> str:
    """The out-of-plane margin's predictions against the trials (tools/world_failures.py)."""
    lines = ["| object (plan) | world | from the world: first leg below 0 (smallest margin) | trials held "
             "| per trial: right, failures predicted |", "|---|---|---|---|---|"]
    first = None
    for r in _study(doc, "trials"):
        if "first_below" not in r:
            continue
        name = f"{OBJECT_NAMES[r['object']]} ({r['primitives']})"
        form = doc["formats"]["smallest_n"]
        if r["first_below"] == "none":
            world_cell = f"none ({show(r['smallest_n'], form)} N, {_leg(r['smallest_leg'])})"
        else:  # the first leg of that name below 0 (a plan may have two legs of one primitive)
            below = next(v for leg, v in r["legs"] if leg == r["first_below"] and (v == "-inf" or float(v) < 0))
            world_cell = f"{_leg(r['first_below'])} ({show(below, form)})"
        lost = ", ".join(f"{what} {n}" for n, what in r["outcomes"] if what != "held")
        held = f"{r['held']}/{r['trials']}" + (f": {lost}" if lost else "")
        caught = f"{r['failures_predicted']}/{r['failures']}" if r["failures"] else "-"
        lines.append(f"| {'' if name == first else name} | {r['world']} | {world_cell} | {held} | "
                     f"{r['right']}/{r['trials']}, {caught} |")
        first = name
    return "\n".join(lines)


def table_wf_needed(doc: dict) -> str:
    """The friction factor each leg of the RRT* plans needs (tools/world_failures.py --needed):
    margin elliptic / pyramidal / planar force closure."""
    lines = ["| object (RRT* seed 1) | press | legs in order |", "|---|---|---|"]
    for o in OBJECTS:
        legs = sorted((r for r in _study(doc, "needed") if r["object"] == o), key=lambda r: r["order"])
        if not legs:
            continue
        cell = lambda r: " / ".join(_f(doc, r, k) for k in ("elliptic", "pyramidal", "closure"))  # noqa: E731
        press = [cell(r) for r in legs if r["leg"] == "press"]
        rest = ", ".join(f"{r['leg']} {cell(r)}" for r in legs if r["leg"] != "press")
        lines.append(f"| {OBJECT_NAMES[o]} | {press[0] if press else '-'} | {rest} |")
    return "\n".join(lines)


def table_wf_cage(doc: dict) -> str:
    """The cage and the out-of-plane margin of several plans per object against the trials they
    hold (tools/world_failures.py --cage); plans whose cells agree share a row."""
    lines = ["| object | plans | primitives | cage: fully caged share | margin at the world's worst draw, friction "
             "x0.7 / pyramidal (N) | held, friction x0.7 | held, pyramidal |", "|---|---|---|---|---|---|---|"]
    merged: dict[tuple, list[str]] = {}
    for r in _study(doc, "cage"):
        if "plan" not in r:
            continue
        cells = (OBJECT_NAMES[r["object"]], r["primitives"], _f(doc, r, "caged_share"),
                 f"{_f(doc, r, 'margin_friction_n')} / {_f(doc, r, 'margin_pyramidal_n')}",
                 f"{r['held_friction']}/{r['trials']}", f"{r['held_pyramidal']}/{r['trials']}")
        plan = re.sub(r"RRTstar seed (\d+) cost", r"RRT* \1", r["plan"])
        merged.setdefault(cells, []).append(re.sub(r"lattice (\w+)", r"lattice `\1`", plan))
    for (obj, primitives, *rest), plans in merged.items():
        lines.append(f"| {obj} | {', '.join(plans)} | {primitives} | " + " | ".join(rest) + " |")
    return "\n".join(lines)


#: The --forces reading model.md's table shows.
FORCES_STUDY = "forces: guitar_pick, trial 0"


def table_wf_forces(doc: dict) -> str:
    """The contact forces of one trial at ticks of its settling and after (tools/world_failures.py
    --forces; bold: a contact at its friction limit, sliding)."""
    lines = ["| world | t (s) | out of the plane: total (roll, yaw), deg | theta (deg) | G across (mm) "
             "| G: N (N), in plane / N, mu | A: N, in plane / N (across / N), mu, mm from G "
             "| B: N, in plane / N, mu, mm from G |", "|---|---|---|---|---|---|---|---|"]
    for r in _study(doc, FORCES_STUDY):
        if "t_s" not in r:
            continue
        cells = []
        for c in "gab":
            if r[f"{c}_n"] is None:
                cells.append("none")
                continue
            ratio = _f(doc, r, f"{c}_in_plane")
            if r[f"{c}_in_plane"] >= 0.99 * r[f"{c}_mu"]:
                ratio = f"**{ratio}**"
            across = f" ({_f(doc, r, 'a_across')})" if c == "a" else ""
            at = "" if c == "g" else f", {_f(doc, r, f'{c}_at_mm')}"
            cells.append(f"{_f(doc, r, f'{c}_n')}, {ratio}{across}, {_f(doc, r, f'{c}_mu')}{at}")
        lines.append(f"| {r['world']} | {_f(doc, r, 't_s')} | {_f(doc, r, 'out_deg')} ({_f(doc, r, 'roll_deg')}, "
                     f"{_f(doc, r, 'yaw_deg')}) | {_f(doc, r, 'theta_deg')} | {_f(doc, r, 'g_across_mm')} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


#: NAME -> the table built from its results files (one, or for grip_rule two).
def _p(p: float | None) -> str:
    """A test's p as the pages show it: two significant figures ("-" where there is none)."""
    return "-" if p is None else f"{p:.2g}"


def table_engines(doc: dict) -> str:
    """The Drake campaign's rows beside MuJoCo's of the same label (sim_campaigns.py --engine drake):
    strict successes with their intervals, the mean errors, the two-sided Fisher test's p."""
    lines = ["| row | MuJoCo (95 % interval) | Drake (95 % interval) | mean error, MuJoCo / Drake | Fisher p "
             "| Drake's failures |", "|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        m = r["mujoco"]
        mujoco = "-" if m is None else FIELDS["strict_interval"](m)
        errors = f"{'-' if m is None else _mm(m['error_mean_mm'])} / {_mm(r['error_mean_mm'])}"
        lines.append(f"| {r['label']} | {mujoco} | {FIELDS['strict_interval'](r)} | {errors} | {_p(r['fisher_p'])} | "
                     f"{FIELDS['failures'](r)} |")
    return "\n".join(lines)


def table_versus(doc: dict, before: dict) -> str:
    """Two runs of the same rows, row by row (the rows of doc that before has too): each one's
    strict successes with their intervals and mean errors, and the two-sided Fisher test's p."""
    lines = ["| row | first (95 % interval) | second (95 % interval) | mean error, first / second | Fisher p |",
             "|---|---|---|---|---|"]
    theirs = {r["key"]: r for r in before["rows"]}
    for r in doc["rows"]:
        b = theirs.get(r["key"])
        if b is None or "successes" not in r:
            continue
        lines.append(f"| {r['label']} | {FIELDS['strict_interval'](r)} | {FIELDS['strict_interval'](b)} | "
                     f"{_mm(r['error_mean_mm'])} / {_mm(b['error_mean_mm'])} | {_p(fisher_p(r, b))} |")
    return "\n".join(lines)


#: Two counts agree within chance where the two-sided Fisher exact test's p is at least this
#: (docs/decisions/0111-pyramidal-cones-run-at-the-step-they-converge-at.md).
CHANCE_P = 0.05


def fisher_p(a: dict, b: dict) -> float:
    """The two-sided Fisher exact test's p of two rows' strict successes, each over its own trials."""
    from scipy.stats import fisher_exact

    table = [[a["successes"], a["trials"] - a["successes"]], [b["successes"], b["trials"] - b["successes"]]]
    return float(fisher_exact(table, alternative="two-sided")[1])


def step_ms(doc: dict) -> float:
    """The step (ms) a campaign file's rows ran at: its footer's `timestep S ms`; ValueError for a
    file run at the scenes' own steps, which differ between worlds (record 0111)."""
    m = re.fullmatch(r"timestep ([\d.e+-]+) ms", doc["step"])
    if m is None:
        raise ValueError(f"{doc['table']}: not run at one given step ({doc['step']})")
    return float(m.group(1))


def step_study(*docs: dict) -> dict[str, dict]:
    """The step convergence study of record 0111 from campaign files each run at one step: world
    label -> {"counts": {object: {step_ms: row}}, "steps": the steps (ms) at which all three objects
    ran, coarse to fine, "step_ms": the step the record's rule gives, "converged": whether the
    finest step agrees with the next coarser for every object}. The rule: the coarsest step at which
    every object's count, and every finer step's, agrees within chance (CHANCE_P) with the finest's."""
    study: dict[str, dict] = {}
    for doc in docs:
        step = step_ms(doc)
        for label, group in worlds(doc).items():
            counts = study.setdefault(label, {"counts": {}})["counts"]
            for obj, row in group.items():
                counts.setdefault(obj, {})[step] = row
    for entry in study.values():
        counts = entry["counts"]
        steps = sorted(set.intersection(*(set(c) for c in counts.values())), reverse=True)
        finest = steps[-1]
        agrees = [all(fisher_p(counts[o][t], counts[o][finest]) >= CHANCE_P for o in counts) for t in steps]
        chosen = next(t for k, t in enumerate(steps) if all(agrees[k:]))
        converged = len(steps) > 1 and all(fisher_p(counts[o][steps[-2]], counts[o][finest]) >= CHANCE_P
                                           for o in counts)
        entry.update(steps=steps, step_ms=chosen, converged=converged)
    return study


#: Record 0112's rows of the elliptic world: those seen before it, and those that test it.
SEEN_WORLDS = ("as modelled", "friction x0.7", "friction x1.3")
TEST_WORLDS = ("density x0.5", "density x2", "stiffness x0.25 (time constant x2)")


def pooled(study: dict[str, dict], labels: tuple[str, ...]) -> dict[float, dict]:
    """The strict successes of the worlds labels (every object's row) pooled per step, at the steps
    where all of them ran: step_ms -> {"successes", "trials"}."""
    rows = [c for label in labels for c in study[label]["counts"].values()]
    steps = sorted(set.intersection(*(set(c) for c in rows)), reverse=True)
    return {t: {"successes": sum(c[t]["successes"] for c in rows), "trials": sum(c[t]["trials"] for c in rows)}
            for t in steps}


def elliptic_step(study: dict[str, dict]) -> float:
    """Record 0112's rule on its test rows (TEST_WORLDS, pooled): 0.1 ms unless it differs from
    0.025 ms beyond chance; then the coarser of 0.05 and 0.025 ms that agrees with 0.025 ms."""
    counts = pooled(study, TEST_WORLDS)
    if fisher_p(counts[0.1], counts[0.025]) >= CHANCE_P:
        return 0.1
    return 0.05 if fisher_p(counts[0.05], counts[0.025]) >= CHANCE_P else 0.025


def table_steps(*docs: dict) -> str:
    """Per world and object the strict successes at each step of the study (step_study), each with
    the Fisher p against the finest step's count; for a pyramidal world, the step record 0111's
    rule gives it."""
    study = step_study(*docs)
    steps = sorted({t for e in study.values() for c in e["counts"].values() for t in c}, reverse=True)
    lines = ["| world | object | " + " | ".join(f"{t:g} ms" for t in steps) + " | the world's step (record 0111) |",
             "|---" * (len(steps) + 3) + "|"]
    for label, entry in study.items():
        finest = entry["steps"][-1]
        for k, obj in enumerate(o for o in OBJECTS if o in entry["counts"]):
            cells = []
            for t in steps:
                row = entry["counts"][obj].get(t)
                if row is None:
                    cells.append("")
                    continue
                p = "" if t == finest else f" (p {_p(fisher_p(row, entry['counts'][obj][finest]))})"
                cells.append(f"{row['successes']}/{row['trials']}{p}")
            rule = ""
            if k == 0 and "pyramidal" in label:
                rule = f"{entry['step_ms']:g} ms" + ("" if entry["converged"] else ", convergence not shown")
            lines.append(f"| {label if k == 0 else ''} | {OBJECT_NAMES[obj]} | " + " | ".join(cells) + f" | {rule} |")
    return "\n".join(lines)


def table_steps_pooled(*docs: dict) -> str:
    """Record 0112: the elliptic rows' strict successes pooled over the three objects and their
    worlds, per step, with the Fisher p against 0.025 ms's; the step its rule gives."""
    study = step_study(*docs)
    lines = ["| rows | " + " | ".join(f"{t:g} ms" for t in (0.1, 0.05, 0.025)) + " | the step (record 0112) |",
             "|---|---|---|---|---|"]
    for name, labels in (("seen before record 0112", SEEN_WORLDS), ("record 0112's test", TEST_WORLDS)):
        counts = pooled(study, labels)
        cells = []
        for t in (0.1, 0.05, 0.025):
            c = counts.get(t)
            p = "" if c is None or t == 0.025 else f" (p {_p(fisher_p(c, counts[0.025]))})"
            cells.append("" if c is None else f"{c['successes']}/{c['trials']}{p}")
        rule = f"{elliptic_step(study):g} ms" if labels == TEST_WORLDS else ""
        lines.append(f"| {name}: {', '.join(labels)} | " + " | ".join(cells) + f" | {rule} |")
    return "\n".join(lines)


TABLES = {"objects": table_objects, "single": table_single, "worlds": table_worlds, "readme": table_readme,
          "readme_worlds": table_readme_worlds, "grip_rule": table_grip_rule, "landing": table_landing,
          "landing_scenes": table_landing_scenes, "wf_trials": table_wf_trials, "wf_needed": table_wf_needed,
          "wf_cage": table_wf_cage, "wf_forces": table_wf_forces, "engines": table_engines, "versus": table_versus,
          "steps": table_steps, "steps_pooled": table_steps_pooled}


#: The tables of one campaign file that, given several (SOURCE+SOURCE:NAME), show their rows joined,
#: in the files' order: row groups of the same code run apart (`sim_campaigns.py --only`).
JOINED = frozenset({"objects", "single", "worlds", "readme_worlds"})


def joined(docs: list[dict]) -> dict:
    """One campaign file of docs' rows, in their order; the first file's other fields."""
    return {**docs[0], "rows": [r for doc in docs for r in doc["rows"]]}


def table(spec: str) -> str:
    """The table SOURCE:NAME, or SOURCE+SOURCE:NAME for a table of two files (JOINED: their rows joined)."""
    sources, name = spec.split(":")
    if name not in TABLES:
        raise KeyError(f"table {spec!r}: no table {name!r}")
    docs = [load(source) for source in sources.split("+")]
    return TABLES[name](joined(docs)) if name in JOINED else TABLES[name](*docs)


# --- a study's results file ----------------------------------------------------------------------

def study_markdown(doc: dict) -> str:
    """The markdown of a study's results file: its title, then per study its command, day, wall
    time and environment (where recorded) and a table of its rows (every field, as the file's
    formats show it)."""
    from ungrasp_ompl.provenance import describe

    lines = [f"# {doc['title']}", "", "Rendered from the JSON beside this file (tools/campaign_results.py); "
             "the JSON is the source.", ""]
    for meta in (r for r in doc["rows"] if r["label"].startswith("study: ")):
        name = meta["label"].removeprefix("study: ")
        rows = [r for r in doc["rows"] if r.get("study") == name and r is not meta]
        where = f" With {describe(meta['environment'])}." if "environment" in meta else ""
        lines += [f"## {name}", "",
                  f"`{meta['command']}`, {meta['produced']}, {meta['seconds']:.0f} s of wall time.{where}", ""]
        kinds: dict[tuple, list[dict]] = {}  # the rows with the same fields make one table
        for r in rows:
            kinds.setdefault(tuple(k for k in r if k not in ("key", "study", "label")), []).append(r)
        for columns, group in kinds.items():
            lines.append("| row | " + " | ".join(columns) + " |")
            lines.append("|---" * (len(columns) + 1) + "|")
            for r in group:
                cells = [show(r[c], doc["formats"].get(c, "{}")) for c in columns]
                lines.append(f"| {r['key']} | " + " | ".join(cells) + " |")
            lines.append("")
    return "\n".join(lines)


def merge_study(path: Path, study: str, command: str, seconds: float, rows: list[dict], formats: dict[str, str],
                title: str, produced: str | None = None, prefixed: bool = False) -> Path:
    """Write one study's rows into the results file at path (JSON; the rows of its other studies
    kept, this study's earlier ones replaced), with its row "study: NAME" (command, wall time, day),
    and the markdown rendered from it beside it; both atomically. The study's row records the
    environment it ran in (ungrasp_ompl.provenance). Each row needs a label; its key is made from it
    and must be new in the file: prefixed puts "STUDY: " before each label, so that a second study
    of the same rows (a tool's --study) keeps keys of its own."""
    from ungrasp_ompl.provenance import environment

    doc = json.loads(path.read_text()) if path.exists() else {"title": title, "formats": {}, "rows": []}
    kept = [r for r in doc["rows"] if r.get("study") != study and r["label"] != f"study: {study}"]
    meta = {"label": f"study: {study}", "study": study, "command": command, "seconds": round(seconds, 1),
            "minutes": round(seconds / 60), "produced": produced or date.today().isoformat(),
            "environment": environment()}
    if prefixed:
        rows = [{**r, "label": f"{study}: {r['label']}"} for r in rows]
    new = [study_row(study, r) for r in (meta, *rows)]
    keys = [r["key"] for r in kept + new]
    if len(set(keys)) != len(keys):
        raise ValueError(f"{path}: two rows share a key: {sorted(k for k in keys if keys.count(k) > 1)}")
    write_study_file(path, {**doc, "title": title, "formats": {**doc["formats"], **formats}, "rows": kept + new})
    return path


def study_row(study: str, row: dict) -> dict:
    """A row as a study's results file keeps it: its key made from its label, then its fields and
    the study's name."""
    return {"key": row_key(row["label"]), **row, "study": study}


def write_study_file(path: Path, doc: dict) -> None:
    """A study's results file (JSON) at path and its markdown rendered from it beside it, both atomically."""
    from ungrasp_ompl.io import write_text_atomic

    write_text_atomic(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    write_text_atomic(path.with_suffix(".md"), study_markdown(doc) + "\n")


# --- the pages ---------------------------------------------------------------------------------

FIG = re.compile(r"<!-- fig (\S+) -->(.*?)<!-- /fig -->")
#: A marked table: its opening mark, its name, its rows (none yet in a page being written) and its
#: closing mark; the rows never reach past another table's mark.
TABLE = re.compile(r"(<!-- table (\S+) -->\n)((?:(?!<!-- /?table ).)*?)\n?(<!-- /table -->)", re.S)


def render(text: str) -> str:
    """The page with every marked figure and table as its results file has it."""
    cache: dict = {}
    text = FIG.sub(lambda m: f"<!-- fig {m.group(1)} -->{figure(m.group(1), cache)}<!-- /fig -->", text)
    return TABLE.sub(lambda m: m.group(1) + table(m.group(2)) + "\n" + m.group(4), text)


def differences(text: str) -> list[str]:
    """Each marked figure or table whose text is not its results file's: mark, found, expected."""
    cache: dict = {}
    out = [f"{m.group(1)}: {m.group(2)!r}, the file has {figure(m.group(1), cache)!r}"
           for m in FIG.finditer(text) if m.group(2) != figure(m.group(1), cache)]
    out += [f"table {m.group(2)}:\n{m.group(3)}\nthe file gives:\n{table(m.group(2))}"
            for m in TABLE.finditer(text) if m.group(3) != table(m.group(2))]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--from-markdown", type=Path, nargs="*", default=[],
                    help="campaign tables (markdown, as sim_campaigns.py --table writes them) to write as JSON beside")
    ap.add_argument("--command", default=None, help="the command that wrote the table (default: sim_campaigns.py "
                                                    "--table with the table's path)")
    ap.add_argument("--produced", default=None, help="the day the table was produced (default: its last commit's)")
    ap.add_argument("--study-markdown", nargs="*", default=[], metavar="SOURCE",
                    help="render docs/results/SOURCE.md again from SOURCE.json (a study's results file)")
    ap.add_argument("--render", type=Path, nargs="*", default=[], help="pages whose marks to fill in")
    ap.add_argument("--check", type=Path, nargs="*", default=[], help="pages whose marks to compare")
    args = ap.parse_args()
    for table in args.from_markdown:
        command = args.command or f"python tools/sim_campaigns.py --table {table}"
        print(f"wrote {write_json(table, command, args.produced or last_commit_day(table))}")
    for source in args.study_markdown:
        from ungrasp_ompl.io import write_text_atomic

        write_text_atomic(RESULTS / f"{source}.md", study_markdown(load(source)) + "\n")
        print(f"rendered {RESULTS / source}.md")
    for page in args.render:
        page.write_text(render(page.read_text()))
        print(f"rendered {page}")
    wrong = [f"{page}: {d}" for page in args.check for d in differences(page.read_text())]
    print("\n".join(wrong) or ("every mark agrees" if args.check else ""), end="\n" if wrong or args.check else "")
    return 1 if wrong else 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
