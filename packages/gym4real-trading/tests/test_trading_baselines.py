from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pandas as pd

import gym4real
from gym4real.core.registry import registry
from gym4real.trading import TradingConfig, evaluation

ENV_ID = "gym4real/trading-v0"
SHARED = Path(os.environ["GYM4REAL_DATA_DIR"])


def test_registration_matches_the_manifest_and_presets() -> None:
    reg = registry()
    assert ENV_ID in gym4real.list_envs()
    manifest = dict(
        reversed(line.split(maxsplit=1)) for line in (SHARED / "MANIFEST.sha256").read_text().splitlines() if line
    )
    for name in reg.envs[ENV_ID].datasets:
        spec = reg.datasets[name]
        assert manifest[f"./{spec.path}"] == spec.sha256
        assert hashlib.sha256((SHARED / spec.path).read_bytes()).hexdigest() == spec.sha256
    assert sorted(reg.envs[ENV_ID].presets) == TradingConfig.presets()
    assert sorted(reg.baselines[ENV_ID]) == ["buy_and_hold", "flat", "hindsight", "random", "sell_and_hold"]
    assert {(a, p) for (e, a, p) in reg.trainings if e == ENV_ID} == {
        (a, p) for a in ("ppo", "dqn") for p in ("paper", "smoke", "hourly")
    }
    # the hourly stand-in of the paper's minute data is what `gym4real reproduce --budget paper` trains
    assert {reg.trainings[(ENV_ID, a, "hourly")].budget for a in ("ppo", "dqn")} == {"paper"}


def test_protocol_lists_every_test_day_in_order() -> None:
    episodes = evaluation.test_episodes({"preset": "test"})
    days = [e["options"]["day"] for e in episodes]
    assert days == sorted(days) and len(days) == len(set(days))
    raw = pd.read_csv(SHARED / "trading" / "eurusd_1h_2017-2018.csv", index_col=0, parse_dates=True)
    est = raw.index - pd.Timedelta(hours=5)
    session = est[(est.hour >= 8) & (est.hour < 16) & (est.day_of_week < 5) & (est >= "2017-11-01")]
    complete = pd.Series(1, session).groupby(session.normalize()).count()
    assert days == [d.strftime("%Y-%m-%d") for d in complete[complete == 8].index]


def test_benchmark_of_the_baselines(tmp_path: Path) -> None:
    policies = ["buy_and_hold", "sell_and_hold", "flat", "random"]
    result = gym4real.benchmark(ENV_ID, policies, episodes="test", out=tmp_path)
    bh, sh = np.array(result.returns["buy_and_hold"]), np.array(result.returns["sell_and_hold"])
    np.testing.assert_allclose(bh + sh, -4.0, atol=1e-6)  # every day: P&L cancels, 2 fees each
    assert result.returns["flat"] == [0.0] * len(bh)
    # B&H daily P&L = capital * (close - open) of the session - 2 fees, from the raw file
    raw = pd.read_csv(SHARED / "trading" / "eurusd_1h_2017-2018.csv", index_col=0, parse_dates=True)["Close"]
    raw.index = raw.index - pd.Timedelta(hours=5)
    for ep, ret in zip(result.episodes[:10], bh[:10], strict=True):
        day = raw[ep["options"]["day"]].between_time("08:00", "15:00")
        assert np.isclose(ret, 100_000 * (day.iloc[-1] - day.iloc[0]) - 2, atol=1e-6)
    final = result.final_info["buy_and_hold"]
    np.testing.assert_allclose(np.array(final["cum_pnl"]) - np.array(final["cum_fees"]), bh)
    again = gym4real.benchmark(ENV_ID, ["random"], episodes="test")
    assert again.returns["random"] == result.returns["random"]  # seeded per day
    paths = evaluation.pnl_figures(result, tmp_path)
    for p in [*paths, tmp_path / "cumulative_reward.png", tmp_path / "returns_boxplot.png"]:
        assert p.stat().st_size > 5000


def test_the_test_protocol_says_it_runs_on_the_hourly_stand_in() -> None:
    from gym4real.bench.benchmark import protocol
    from gym4real.trading.config import TradingConfig

    spec = protocol("gym4real/trading-v0")
    config = TradingConfig.build(None, "test")
    assert config.bar_minutes == 60 and "1h" in str(config.source.dataset)  # hourly bars, not the paper's minutes
    assert "hourly EUR/USD stand-in" in spec.description and "minute data" in spec.description
