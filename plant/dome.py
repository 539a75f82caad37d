"""Dome azimuth plant (issue 12; paper §5.2: dome control "tested in the lab on RS232 ports").

A kinematic model, stated: the dome's drive is a variable-frequency drive that holds the
commanded rotation rate, so the dome rate equals the drive's speed reference times its full
scale (``dome.vfd_full_scale_deg_s``) at once, and the azimuth is its exact integral (piecewise
constant rate between reference changes). The rate and acceleration *limits* are the
firmware's (:class:`boards.dome.DomeController`): the plant does not limit what it is told,
so a test reading the plant's truth checks the firmware's limits independently.

Not modelled: the dome's inertia and drive torque limit, wheel slip, the shutter, wind load,
the encoder's own error (only its quantization).

Convention: azimuth from north through east (N = 0°, E = 90°), kept unwrapped in
:attr:`DomePlant.azimuth_deg` (the truth) and reported modulo 360° by the encoder.
"""

from __future__ import annotations

import math

from plant.params import DomeParameters

__all__ = ["DomePlant"]


class DomePlant:
    """Dome azimuth integrator driven by a speed reference.

    Parameters
    ----------
    params : DomeParameters
        ``load_parameters().dome`` (full-scale rate, encoder resolution, initial azimuth).

    Attributes
    ----------
    azimuth_deg : float
        Unwrapped azimuth at :attr:`now_us` [deg] (truth, for tests and reports).
    rate_deg_s : float
        Present rotation rate [deg/s].
    peak_rate_deg_s : float
        Largest |rate| commanded so far [deg/s] (for the report).
    """

    def __init__(self, params: DomeParameters) -> None:
        self.params = params
        self.now_us = 0
        self.reset(params.initial_azimuth_deg)

    def reset(self, azimuth_deg: float = 0.0) -> None:
        """Dome at rest at ``azimuth_deg``."""
        self.azimuth_deg = float(azimuth_deg)
        self.rate_deg_s = 0.0
        self.peak_rate_deg_s = 0.0

    def advance_to(self, t_us: int) -> None:
        """Integrate the azimuth to ``t_us`` (no-op for an earlier time)."""
        if t_us > self.now_us:
            self.azimuth_deg += self.rate_deg_s * (t_us - self.now_us) * 1e-6
            self.now_us = int(t_us)

    def set_speed_reference(self, fraction: float) -> None:
        """The drive's speed reference, −1 .. 1 of full scale (clipped); call after
        :meth:`advance_to` to the present time."""
        f = max(-1.0, min(1.0, float(fraction)))
        self.rate_deg_s = f * self.params.vfd_full_scale_deg_s
        self.peak_rate_deg_s = max(self.peak_rate_deg_s, abs(self.rate_deg_s))

    def encoder_counts(self) -> int:
        """Absolute azimuth encoder word, 0 .. counts_per_rev − 1 (floor of the azimuth)."""
        n = self.params.encoder_counts_per_rev
        return int(math.floor((self.azimuth_deg % 360.0) / 360.0 * n)) % n
