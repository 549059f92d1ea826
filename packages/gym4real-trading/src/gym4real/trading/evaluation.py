"""The paper's evaluation of TradingEnv: every trading day of a split once, in order.

``gym4real bench gym4real/trading-v0`` runs :func:`test_episodes` and writes the core's table and
figures (its boxplot is the daily P&L); :func:`pnl_figures`, registered as the protocol's figures,
adds the paper's two figures over the days: the cumulative P&L (% of capital) and the boxplot of the
daily P&L (%). They draw with matplotlib, which the harness brings (the ``bench`` extra of gym4real-core),
not this distribution; the environment never draws them.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gym4real.trading import features
from gym4real.trading.config import TradingConfig

if TYPE_CHECKING:
    from gym4real.bench.benchmark import BenchmarkResult

ENV_ID = "gym4real/trading-v0"


def _config(env_kwargs: Mapping[str, Any]) -> TradingConfig:
    extra = {k: v for k, v in env_kwargs.items() if k not in ("config", "preset", "render_mode")}
    return TradingConfig.build(env_kwargs.get("config"), env_kwargs.get("preset"), **extra)


def evaluation_days(env_kwargs: Mapping[str, Any]) -> list[str]:
    """The kept trading days (``YYYY-MM-DD``) of the configured split, in order."""
    return [d.isoformat() for d in features.split_data(_config(env_kwargs)).days]


def test_episodes(env_kwargs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One episode per trading day of the split, in date order (seed = the day's index, for random policies)."""
    return [{"seed": i, "options": {"day": day}} for i, day in enumerate(evaluation_days(env_kwargs))]


def daily_pnl_percent(result: BenchmarkResult, capital: float) -> dict[str, np.ndarray]:
    """Daily P&L (net of fees) in % of the capital, per policy."""
    return {name: np.asarray(rets) / capital * 100 for name, rets in result.returns.items()}


def pnl_figures(result: BenchmarkResult, out: str | Path, capital: float = 100_000.0) -> list[Path]:
    """Write ``cumulative_pnl.png`` (cumulative daily P&L % over the days) and ``daily_pnl_boxplot.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    daily = daily_pnl_percent(result, capital)
    days = [np.datetime64((e.get("options") or {}).get("day", "NaT")) for e in result.episodes]
    dated = all(not np.isnat(d) for d in days)
    paths = [out / "cumulative_pnl.png", out / "daily_pnl_boxplot.png"]
    fig, ax = plt.subplots(figsize=(8, 4))
    for name, pnl in daily.items():
        x = np.array(days[: len(pnl)]) if dated else np.arange(1, len(pnl) + 1)
        ax.plot(x, np.cumsum(pnl), label=result.labels[name])
    ax.axhline(0, color="grey", lw=0.5)
    ax.set(xlabel="day" if dated else "episode", ylabel="cumulative P&L (% of capital)")
    ax.set_title(f"{result.env_id}: cumulative P&L over {len(result.episodes)} trading days")
    ax.legend()
    fig.autofmt_xdate()
    fig.tight_layout()
    fig.savefig(paths[0], dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 4))
    names = list(daily)
    ax.boxplot([daily[n] for n in names], tick_labels=[result.labels[n] for n in names])
    ax.axhline(0, color="grey", lw=0.5)
    ax.set(ylabel="daily P&L (% of capital)", title=f"{result.env_id}: daily P&L")
    fig.tight_layout()
    fig.savefig(paths[1], dpi=120)
    plt.close(fig)
    return paths
