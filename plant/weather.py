"""Weather at the site: a documented, seeded time series (issue 12; paper §5.2: the weather
station was "tested in the lab on RS232 ports").

The model (all numbers in ``plant/parameters.yaml`` ``weather``, overridable from a scenario):

* **temperature** T(t) = mean + A·cos(2π(h(t) − 14 h)/24 h) + e_T, with h(t) the local solar hour
  (``start_local_hour`` at t = 0) and e_T white noise of std ``temperature_noise_c`` per sample;
* **relative humidity** RH = clip(mean + x_H, 0, 100), x_H an Ornstein–Uhlenbeck (AR(1) at the
  sample step) process of stationary std ``humidity_noise_pct`` and time constant ``humidity_tau_s``;
* **wind speed** W = max(0, mean + x_W), x_W an OU process (``wind_noise_m_s``, ``wind_tau_s``);
* **rain** (the rain sensor, wet or dry): seeded episodes of ``rain_duration_s`` starting as a
  Poisson process of rate ``rain_rate_per_h`` (0 by default: no random rain);
* **scripted events** (scenario ``weather.events``): ``gust`` raises the wind to at least
  ``wind_m_s`` for ``duration_s``; ``rain`` wets the rain sensor for ``duration_s``.

Deterministic: the series is a function of the seed and the sample index k = ⌊t / step⌋ only
(numpy ``default_rng(seed)``, one fixed draw order per step), however often it is read.
The station's sensors turn it into voltages (:meth:`WeatherModel.temperature_v` ...) with the
transfer functions of the parameter file; thresholds and flags are the station firmware's
(:class:`boards.weather.WeatherStation`).

Not modelled: pressure, dew point, sky temperature / cloud, wind direction, sensor drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plant.params import WeatherParameters

__all__ = ["WeatherModel", "WeatherEvent", "SENSOR_FULL_SCALE_V"]

#: Output span of the station's analog transmitters [V] (assumed 0-5 V, the boards' ADC range).
SENSOR_FULL_SCALE_V = 5.0


@dataclass(frozen=True)
class WeatherEvent:
    """A scripted weather event.

    Attributes
    ----------
    at_s : float
        Start, simulated seconds since power-on (t = 0).
    kind : {"gust", "rain"}
    duration_s : float
        How long it lasts [s].
    wind_m_s : float
        ``gust``: the wind speed it raises the wind to at least [m/s].
    """

    at_s: float
    kind: str
    duration_s: float
    wind_m_s: float = 0.0

    def active(self, t_s: float) -> bool:
        return self.at_s <= t_s < self.at_s + self.duration_s


class WeatherModel:
    """Seeded weather time series at the sample step.

    Parameters
    ----------
    params : WeatherParameters
        ``load_parameters().weather``.
    seed : int
        Seed of the series (the scenario's ``weather.seed``, default its ``seed``).
    events : sequence of WeatherEvent
        Scripted events.

    Attributes
    ----------
    temperature_c, humidity_pct, wind_m_s : float
        The values of the present sample (after :meth:`advance_to`).
    rain : bool
        The rain sensor is wet.
    """

    def __init__(self, params: WeatherParameters, seed: int = 0, events=()) -> None:
        self.params = params
        self.seed = int(seed)
        self.events = tuple(events)
        for e in self.events:
            if e.kind not in ("gust", "rain"):
                raise ValueError(f"weather event kind must be 'gust' or 'rain', got {e.kind!r}")
        self._step_s = params.sample_period_us * 1e-6
        self._rng = np.random.default_rng(self.seed)
        self._a_h = math.exp(-self._step_s / params.humidity_tau_s)
        self._a_w = math.exp(-self._step_s / params.wind_tau_s)
        self._p_rain = 1.0 - math.exp(-params.rain_rate_per_h * self._step_s / 3600.0)
        # stationary start: draw the first OU states from their stationary distributions
        self._x_h = params.humidity_noise_pct * self._rng.standard_normal()
        self._x_w = params.wind_noise_m_s * self._rng.standard_normal()
        self._rain_until_s = -1.0
        self.k = -1
        self.now_us = 0
        self._step()

    def _step(self) -> None:
        """Advance the series by one sample (fixed draw order: T noise, H, W, rain)."""
        p = self.params
        self.k += 1
        t_s = self.k * self._step_s
        e = self._rng.standard_normal(3)
        u = self._rng.random()
        if self.k > 0:
            self._x_h = self._a_h * self._x_h + p.humidity_noise_pct * math.sqrt(1 - self._a_h ** 2) * e[1]
            self._x_w = self._a_w * self._x_w + p.wind_noise_m_s * math.sqrt(1 - self._a_w ** 2) * e[2]
        hour = (p.start_local_hour + t_s / 3600.0) % 24.0
        self.temperature_c = (p.temperature_mean_c + p.temperature_diurnal_c * math.cos(2 * math.pi * (hour - 14.0) / 24.0)
                              + p.temperature_noise_c * e[0])
        self.humidity_pct = min(100.0, max(0.0, p.humidity_mean_pct + self._x_h))
        wind = max(0.0, p.wind_mean_m_s + self._x_w)
        if u < self._p_rain and t_s >= self._rain_until_s:
            self._rain_until_s = t_s + p.rain_duration_s
        rain = t_s < self._rain_until_s
        for ev in self.events:
            if ev.active(t_s):
                if ev.kind == "gust":
                    wind = max(wind, ev.wind_m_s)
                else:
                    rain = True
        self.wind_m_s = wind
        self.rain = rain

    def advance_to(self, t_us: int) -> None:
        """Make the present sample the one of time ``t_us`` (sample k = ⌊t / step⌋)."""
        k = int(t_us) // self.params.sample_period_us
        while self.k < k:
            self._step()
        self.now_us = max(self.now_us, int(t_us))

    # -- the station's analog inputs ------------------------------------------------------------
    def temperature_v(self) -> float:
        """Temperature transmitter output [V]: linear, ``temperature_min_c`` at 0 V to
        ``temperature_max_c`` at 5 V (clipped)."""
        p = self.params
        f = (self.temperature_c - p.temperature_min_c) / (p.temperature_max_c - p.temperature_min_c)
        return SENSOR_FULL_SCALE_V * min(1.0, max(0.0, f))

    def humidity_v(self) -> float:
        """Humidity transmitter output [V]: 0-100 % over 0-5 V."""
        return SENSOR_FULL_SCALE_V * self.humidity_pct / 100.0

    def wind_v(self) -> float:
        """Anemometer transmitter output [V]: 0 .. ``wind_full_scale_m_s`` over 0-5 V (clipped)."""
        return SENSOR_FULL_SCALE_V * min(1.0, self.wind_m_s / self.params.wind_full_scale_m_s)
