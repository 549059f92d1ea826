"""Registration of the trading domain (imports nothing heavier than the core's records)."""

from __future__ import annotations

from gym4real.core.hookspecs import hookimpl
from gym4real.core.specs import BaselineSpec, BenchmarkSpec, Claim, DatasetSpec, EnvSpec, TrainingSpec

#: The gym4real plugin API this module is written for (checked against gym4real-core's PLUGIN_API_VERSION).
plugin_api = "0.2"

ENV_ID = "gym4real/trading-v0"
#: Margin of practical equivalence of the negative claims, in USD of daily P&L (about 0.01 % of the position).
MARGIN = 10.0
PRESETS = (
    "default",
    "train",
    "validation",
    "test",
    "paper_train",
    "paper_validation",
    "paper_test",
    "paper_benchmark",
)


@hookimpl
def gym4real_register_envs() -> list[EnvSpec]:
    """The trading environment."""
    return [
        EnvSpec(
            id=ENV_ID,
            entry_point="gym4real.trading.env:TradingEnv",
            vector_entry_point="gym4real.trading.vector:TradingVectorEnv",
            description="Intraday EUR/USD trading on historical mid prices, one trading day per episode",
            flags=frozenset(
                {
                    "continuous_states",
                    "partially_observable",
                    "partially_controllable",
                    "non_stationary",
                    "frequency_adaptation",
                    "risk_averse",
                }
            ),
            presets=PRESETS,
            datasets=("trading/eurusd_1h_ask_2017", "trading/eurusd_1h_2017-2018"),
        )
    ]


#: What the hourly files stand in for.
HISTDATA = "the paper's 2019-2022 EUR/USD one-minute HistData bars (`gym4real data fetch trading --years ...`)"


@hookimpl
def gym4real_register_datasets() -> list[DatasetSpec]:
    """The two real hourly EUR/USD files, stand-ins for the paper's minute data (fetched by users)."""
    return [
        DatasetSpec(
            name="trading/eurusd_1h_ask_2017",
            path="trading/eurusd_1h_ask_2017.csv",
            sha256="28398b7edff9f74860d35a6f3c263f08e15c55264316dc07737d459d8688d7aa",
            url="https://raw.githubusercontent.com/AminHP/gym-anytrading/master/gym_anytrading/datasets/data/FOREX_EURUSD_1H_ASK.csv",
            licence="MIT (gym-anytrading)",
            description="EUR/USD hourly ask OHLCV, 2017, Dukascopy export (UTC)",
            stand_in_for=HISTDATA,
        ),
        DatasetSpec(
            name="trading/eurusd_1h_2017-2018",
            path="trading/eurusd_1h_2017-2018.csv",
            sha256="81e977905a006cc8fbc034ebdb83c999a8ed6ba00191dc7ea5ef5b386fb74a82",
            url="https://raw.githubusercontent.com/kernc/backtesting.py/0.6.6/backtesting/test/EURUSD.csv",
            licence="AGPL-3.0 (backtesting.py)",
            description="EUR/USD hourly OHLCV, 2017-04-19 .. 2018-02-07 (UTC)",
            stand_in_for=HISTDATA,
        ),
    ]


@hookimpl
def gym4real_register_baselines() -> list[BaselineSpec]:
    """Buy&Hold, Sell&Hold, always flat and random; the hindsight planner (a non-causal upper reference)."""
    return [
        BaselineSpec(ENV_ID, "buy_and_hold", "gym4real.trading.baselines:buy_and_hold", "always long (B&H)"),
        BaselineSpec(ENV_ID, "sell_and_hold", "gym4real.trading.baselines:sell_and_hold", "always short (S&H)"),
        BaselineSpec(ENV_ID, "flat", "gym4real.trading.baselines:flat", "never in the market"),
        BaselineSpec(ENV_ID, "random", "gym4real.core.policies:random_policy", "uniform random actions"),
        BaselineSpec(
            ENV_ID,
            "hindsight",
            "gym4real.trading.hindsight:hindsight",
            "upper reference: exact dynamic programming over the position knowing the day's prices",
            causal=False,
            bound="exact",
            bound_note="backward induction over the three positions is the optimum of the day; a test finds it equal "
            "to the best of all 3^7 action sequences stepped through the env",
        ),
    ]


@hookimpl
def gym4real_register_benchmarks() -> list[BenchmarkSpec | TrainingSpec]:
    """Every day of the evaluation split, in order; the PPO and DQN presets."""
    return [
        BenchmarkSpec(
            env_id=ENV_ID,
            protocol="gym4real.trading.evaluation:test_episodes",
            env_kwargs={"preset": "test"},
            policies=("buy_and_hold", "sell_and_hold", "flat", "random"),
            rule_based=("buy_and_hold", "sell_and_hold", "flat"),
            objective=("pnl", "fees"),
            final_info=("cum_pnl", "cum_fees"),
            figures="gym4real.trading.evaluation:pnl_figures",
            description="every trading day of the test split, in order (daily P&L in USD), on the hourly EUR/USD "
            "stand-in (2017-2018 hourly bars; the paper's 2019-2022 HistData minute data is fetched by users)",
            step_unit="hour of the trading day",
            claims=tuple(
                claim
                for algo, name in (("ppo", "PPO"), ("dqn", "DQN"))
                for claim in (
                    Claim(
                        f"{name} does not consistently outperform the passive baselines (Sec. 2.5: Buy&Hold and "
                        f"Sell&Hold); margin reading {MARGIN:g} USD per day: a gain below about 0.01 % a day of the "
                        "100,000 EUR position (about 2.5 % a year) is of no practical consequence for an intraday "
                        "strategy",
                        algo,
                        "not_above",
                        ("buy_and_hold", "sell_and_hold"),
                        margin=MARGIN,
                        consistently=True,
                        section="2.5",
                    ),
                    Claim(
                        f"{name} reduces the daily variability of the P&L (Sec. 2.5; the sentence names no "
                        "baselines: those of its figure, Buy&Hold and Sell&Hold)",
                        algo,
                        "less_variable",
                        ("buy_and_hold", "sell_and_hold"),
                        section="2.5",
                    ),
                )
            ),
        ),
        *(
            TrainingSpec(ENV_ID, algo, preset, f"gym4real.trading:rl/{algo}_{preset}.yaml")
            for algo in ("ppo", "dqn")
            for preset in ("paper", "smoke")
        ),
        # the hourly EUR/USD stand-in of the paper's minute data, run by `gym4real reproduce --budget paper`
        *(
            TrainingSpec(ENV_ID, algo, "hourly", f"gym4real.trading:rl/{algo}_hourly.yaml", budget="paper")
            for algo in ("ppo", "dqn")
        ),
    ]
