"""Issue 43's sections of the JAX trainer: their claims checked on `ppo-jax`, and the JAX trainer against SB3."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from gym4real.bench.numbers import human
from gym4real.core.errors import ConfigError
from gym4real.results import trainer_comparison
from gym4real.results.analysis import analyse, check_claims, recheck
from gym4real.results.claims import on_trainer
from gym4real.results.results_page import write_page

ROOT = Path(__file__).resolve().parents[1]
DAM = ROOT / "docs" / "results" / "dam-v0-paper"
#: The published section of the JAX trainer's dam runs (issue 43), once the page holds it.
DAM_JAX = ROOT / "docs" / "results" / "dam-v0-paper-jax"
SEEDS = (0, 1, 2, 3)


def _episodes(agents: dict[str, np.ndarray], baselines: dict[str, np.ndarray] | None = None) -> pd.DataFrame:
    """``episodes.csv`` of trained agents (one row of the matrix per seed) and baselines (one row, no seed)."""
    rows = [
        {"policy": name, "seed": seed, "episode": j, "objective": float(v), "return": float(v)}
        for name, matrix in agents.items()
        for seed, row in zip(SEEDS, matrix, strict=False)
        for j, v in enumerate(row)
    ]
    rows += [
        {"policy": name, "seed": None, "episode": j, "objective": float(v), "return": float(v)}
        for name, row in (baselines or {}).items()
        for j, v in enumerate(row)
    ]
    return pd.DataFrame(rows)


def _numpy_difference(a: np.ndarray, b: np.ndarray, seed: int, reps: int = 20_000) -> tuple[float, float, float]:
    """IQM(a) - IQM(b) and its 95 % two-level percentile interval, by numpy and scipy alone: every replicate
    draws the episodes once for both matrices and each matrix's rows (training seeds) on their own."""
    rng = np.random.default_rng(seed)
    episodes = a.shape[1]
    cols = rng.integers(episodes, size=(reps, 1, episodes))
    drawn = [m[rng.integers(len(m), size=(reps, len(m), 1)), cols].reshape(reps, -1) for m in (a, b)]
    values = sps.trim_mean(drawn[0], 0.25, axis=1) - sps.trim_mean(drawn[1], 0.25, axis=1)
    low, high = np.percentile(values, [2.5, 97.5])
    point = sps.trim_mean(a, 0.25, axis=None) - sps.trim_mean(b, 0.25, axis=None)
    return float(point), float(low), float(high)


def _agrees_with_numpy(record: dict, a: np.ndarray, b: np.ndarray) -> None:
    """The record's difference is numpy's; its ends are within a tenth of the interval's width of numpy's."""
    point, low, high = _numpy_difference(a, b, seed=12345)
    assert record["estimate"] == pytest.approx(point, rel=1e-9, abs=1e-9)
    width = high - low
    assert abs(record["low"] - low) <= 0.1 * width and abs(record["high"] - high) <= 0.1 * width, (record, low, high)


def _trainers(shift: float, noise: float = 1.0) -> tuple[pd.DataFrame, pd.DataFrame, np.ndarray, np.ndarray]:
    """SB3's and the JAX trainer's episodes on 20 episodes of increasing difficulty; JAX's shifted by ``shift``."""
    rng = np.random.default_rng(0)
    hardness = np.linspace(-100.0, 0.0, 20)
    sb3 = hardness + rng.normal(0.0, noise, (4, 20))
    jax = hardness + shift + rng.normal(0.0, noise, (4, 20))
    return _episodes({"ppo": sb3}, {"random": hardness - 50}), _episodes({"ppo-jax": jax}), jax, sb3


@pytest.mark.parametrize(
    ("shift", "verdict", "rule", "side"),
    [
        (0.0, "holds", "not detectably worse", "contains 0"),
        (10.0, "holds", "not detectably worse", "above 0"),
        (-10.0, "refuted", "detectably worse", "below 0"),
    ],
)
def test_the_jax_trainer_is_equal_within_noise_unless_its_whole_interval_lies_below_sb3s(
    shift: float, verdict: str, rule: str, side: str
) -> None:
    sb3, jax, a, b = _trainers(shift)
    record = trainer_comparison.compare(sb3, jax, "jax")
    where = {"contains 0": record["low"] < 0 < record["high"], "above 0": record["low"] > 0}
    where["below 0"] = record["high"] < 0
    assert where[side], record
    assert (record["verdict"], record["rule"], record["a"], record["b"]) == (verdict, rule, "ppo-jax", "ppo")
    assert record["a_seeds"] == record["b_seeds"] == list(SEEDS) and record["episodes"] == 20
    _agrees_with_numpy(record, a, b)
    for key, matrix in (("a", a), ("b", b)):  # each agent's IQM: all its seeds' episodes
        assert record[f"{key}_iqm"] == pytest.approx(sps.trim_mean(matrix, 0.25, axis=None))
        assert record[f"{key}_low"] < record[f"{key}_iqm"] < record[f"{key}_high"]


def test_the_rules_decide_on_the_intervals_end_and_are_written_for_the_page() -> None:
    assert trainer_comparison.verdict(-5.0, 0.0) == ("holds", "not detectably worse")  # reaches 0: not worse
    assert trainer_comparison.verdict(-5.0, -1e-9) == ("refuted", "detectably worse")
    assert trainer_comparison.verdict(1.0, 2.0) == ("holds", "not detectably worse")
    assert set(trainer_comparison.RULES) == {"not detectably worse", "detectably worse"}
    assert "contains 0 or lies above" in trainer_comparison.RULES["not detectably worse"]
    assert "below 0" in trainer_comparison.RULES["detectably worse"]


def test_a_comparison_needs_both_agents_on_the_same_test_episodes() -> None:
    sb3, jax, _, _ = _trainers(0.0)
    with pytest.raises(ConfigError, match=r"`sb3.csv` has no training seeds of `ppo`"):
        trainer_comparison.compare(jax, jax, "jax", ("sb3.csv", "jax.csv"))
    with pytest.raises(ConfigError, match=r"`jax.csv` and `sb3.csv` hold different test episodes \(19 and 20\)"):
        trainer_comparison.compare(sb3, jax[jax["episode"] < 19], "jax", ("sb3.csv", "jax.csv"))


def _dam(agent: str) -> pd.DataFrame:
    """Dam's test years with `agent` (4 seeds) far above every baseline and below `mpc`."""
    years = np.linspace(-20_000.0, -5_000.0, 13)
    rng = np.random.default_rng(1)
    baselines = {name: years - 8_000 - 1_000 * i for i, name in enumerate(("random", "mean", "max", "ead"))}
    return _episodes({agent: years + rng.normal(0, 100, (4, 13))}, {**baselines, "mpc": years + 4_000})


def test_a_jax_sections_claims_are_decided_on_ppo_jax_and_name_it() -> None:
    claims = check_claims("gym4real/dam-v0", "paper", _dam("ppo-jax"), "jax")
    assert [c["verdict"] for c in claims] == ["holds", "refuted"]
    for c in claims:
        assert c["policy"] == "ppo-jax" and c["trainer"] == "jax"
        assert c["text"].endswith(" (PPO trained by the JAX trainer, `ppo-jax`)")
        assert {x["a"] for x in c["comparisons"]} == {"ppo-jax"}
    # the same rows read as an SB3 section have no `ppo`: not checked, as a JAX section without `ppo-jax`
    for trainer, frame in (("sb3", _dam("ppo-jax")), ("jax", _dam("ppo"))):
        missing = check_claims("gym4real/dam-v0", "paper", frame, trainer)
        assert {c["verdict"] for c in missing} == {"not checked"} and not any(c["comparisons"] for c in missing)
        assert ("trainer" in missing[0]) is (trainer == "jax")


def test_an_sb3_sections_claims_are_the_protocols_and_a_jax_sections_swap_ppo_alone() -> None:
    from gym4real.bench.benchmark import protocol
    from gym4real.core.specs import Claim

    sb3 = check_claims("gym4real/dam-v0", "paper", _dam("ppo"), "sb3")
    jax = check_claims("gym4real/dam-v0", "paper", _dam("ppo-jax"), "jax")
    for c, j, claim in zip(sb3, jax, protocol("gym4real/dam-v0").claims, strict=True):
        assert "trainer" not in c and (c["text"], c["policy"]) == (claim.text, "ppo")
        # the same scores under another name: the same numbers and verdicts
        assert [(x["estimate"], x["low"], x["high"]) for x in c["comparisons"]] == [
            (x["estimate"], x["low"], x["high"]) for x in j["comparisons"]
        ]
    claim = Claim("PPO beats DQN and PPO-less baselines", "dqn", "above", ("ppo", "random"))
    assert on_trainer(claim, "sb3") is claim
    assert on_trainer(claim, "jax").others == ("ppo-jax", "random") and on_trainer(claim, "jax").policy == "dqn"


def test_analyse_and_recheck_take_the_trainer_from_the_folders_name(tmp_path: Path) -> None:
    for name, agent in (("dam-v0-paper-jax", "ppo-jax"), ("dam-v0-paper", "ppo")):
        folder = tmp_path / name
        folder.mkdir()
        _dam(agent).to_csv(folder / "episodes.csv", index=False)
        (folder / "report.json").write_text(json.dumps({"env_id": "gym4real/dam-v0", "budget": "paper"}))
        analysed = analyse(folder, "gym4real/dam-v0", "paper")
        assert {c["policy"] for c in analysed} == {agent} and {c["verdict"] for c in analysed} == {"holds", "refuted"}
        (folder / "claims.json").write_text("[]")
        assert recheck(folder) == analysed == json.loads((folder / "claims.json").read_text())


def _jax_copy_of(sb3: Path, target: Path, shift: float) -> Path:
    """``sb3``'s section as the JAX trainer's (``ppo`` -> ``ppo-jax``, its scores moved by ``shift``), analysed."""
    target.mkdir()
    episodes = pd.read_csv(sb3 / "episodes.csv")
    ppo = episodes["policy"] == "ppo"
    episodes.loc[ppo, "objective"] += shift
    episodes.loc[ppo, "policy"] = "ppo-jax"
    episodes.to_csv(target / "episodes.csv", index=False)
    runs = pd.read_csv(sb3 / "runs.csv")
    runs["algo"] = "ppo-jax"
    runs.to_csv(target / "runs.csv", index=False)
    report = json.loads((sb3 / "report.json").read_text())
    report["presets"], report["command"] = {"ppo-jax": "paper"}, report["command"] + " --trainer jax"
    (target / "report.json").write_text(json.dumps(report))
    analyse(target, report["env_id"], report["budget"])
    return target


def _matrix(folder: Path, policy: str) -> np.ndarray:
    episodes = pd.read_csv(folder / "episodes.csv")
    return episodes[episodes["policy"] == policy].pivot(index="seed", columns="episode", values="objective").to_numpy()


def _rendered_comparison(out: Path, page: Path) -> tuple[str, dict]:
    """Render the sections of ``out`` into ``page``: its text and its one trainer comparison, its files checked."""
    text = write_page(out, page).read_text()
    (record,) = json.loads((page / trainer_comparison.FILE).read_text())
    manifest = json.loads((page / "manifest.json").read_text())
    assert trainer_comparison.FILE in manifest["files"]
    from gym4real.results.artefacts import verify

    assert verify(page).problems == {}
    return text, record


def _shows_comparison(text: str, record: dict) -> None:
    """The page's table row, the JAX section's line and the Methods' rules show the record."""
    difference = f"{human(record['estimate'])} [{human(record['low'])}, {human(record['high'])}]"
    mark = {"holds": "✅", "refuted": "❌"}[record["verdict"]]
    row = [line for line in text.splitlines() if line.startswith("| `dam-v0` | ") and difference in line]
    assert row == [
        f"| `dam-v0` | {human(record['b_iqm'])} [{human(record['b_low'])}, {human(record['b_high'])}] "
        f"| `ppo-jax` {human(record['a_iqm'])} [{human(record['a_low'])}, {human(record['a_high'])}] "
        f"| {difference} | {mark} **{record['verdict']}** | {record['rule']} |"
    ]
    table = text.index("## JAX trainer against SB3")
    jax = text.index("## `gym4real/dam-v0`, budget `paper`, trainer `ppo-jax` (PPO trained by JAX)")
    assert text.index("## Verdicts on the paper's claims") < table < text.index("## `gym4real/dam-v0`") < jax
    line = f"IQM `ppo-jax` - `ppo` {difference} at 0.95: {mark} **{record['verdict']}** ({record['rule']})."
    assert line in text[jax : text.index("## Methods")]
    for name, words in trainer_comparison.RULES.items():
        assert f"- *{name}*: {words}." in text[text.index("## Methods") :]


def test_the_page_shows_the_jax_trainer_against_sb3_from_the_two_sections_episodes(tmp_path: Path) -> None:
    """A page of dam's SB3 section and a JAX section of its scores lowered by 2,000: refuted, as numpy finds."""
    out, page = tmp_path / "out", tmp_path / "page"
    shutil.copytree(DAM, out / DAM.name)
    jax = _jax_copy_of(DAM, out / "dam-v0-paper-jax", -2_000.0)
    text, record = _rendered_comparison(out, page)
    a, b = _matrix(jax, "ppo-jax"), _matrix(DAM, "ppo")
    _agrees_with_numpy(record, a, b)
    assert record["verdict"] == "refuted" and record["high"] < 0
    assert (record["reference"], record["section"], record["env_id"]) == (DAM.name, jax.name, "gym4real/dam-v0")
    summary = pd.read_csv(DAM / "summary.csv", index_col="policy").loc["ppo"]  # the SB3 section's own row
    assert (record["b_iqm"], record["b_low"], record["b_high"]) == (summary["iqm"], summary["low"], summary["high"])
    _shows_comparison(text, record)
    # the page's verdicts: the SB3 section's, then the JAX section's named by its trainer, in claims.json too
    rows = [line for line in text.splitlines() if re.match(r"\| `dam-v0`(<br>[^|]*)? \| PPO ", line)]
    assert len(rows) == 4 and all("<br>trainer `ppo-jax` |" in r for r in rows[1::2])
    assert not any("trainer" in r for r in rows[::2])
    claims = json.loads((page / "claims.json").read_text())
    assert [c.get("trainer", "sb3") for c in claims] == ["sb3", "sb3", "jax", "jax"]
    assert "## Verdicts on the paper's claims (1, and 1 on the runs of the JAX trainer)" in text
    assert write_page(page, page).read_text() == text  # the page folder alone regenerates the page
    shutil.rmtree(jax)  # without a second trainer's section, no comparison and no file of it
    shutil.rmtree(page / jax.name)
    text = write_page(out, page).read_text()
    assert "trainer against SB3" not in text
    assert not (out / trainer_comparison.FILE).exists() and not (page / trainer_comparison.FILE).exists()
    assert "Rules of the trainer comparisons" not in text


@pytest.mark.skipif(not DAM_JAX.is_dir(), reason="the JAX trainer's dam section is not published yet (issue 43)")
def test_the_published_jax_dam_section_is_refuted_as_numpy_recomputes_it(tmp_path: Path) -> None:
    out, page = tmp_path / "out", tmp_path / "page"
    for section in (DAM, DAM_JAX):
        shutil.copytree(section, out / section.name)
    claims = recheck(out / DAM_JAX.name)
    assert {c["policy"] for c in claims} == {"ppo-jax"} and "not checked" not in {c["verdict"] for c in claims}
    text, record = _rendered_comparison(out, page)
    _agrees_with_numpy(record, _matrix(DAM_JAX, "ppo-jax"), _matrix(DAM, "ppo"))
    assert record["verdict"] == "refuted"
    _shows_comparison(text, record)
