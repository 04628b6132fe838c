"""Wetness weakens the ground: the yield strength of soil at saturation θ (seed 003 eq. 15; SPEC SP-2).

    σ_s(θ) = σ₁ + (σ₀ − σ₁)·f(θ),      f(θ) = (e^{(1−θ)²} − 1)/(e − 1),      θ ∈ [0, 1]

σ₀ is the dry ground's yield strength (θ = 0, f = 1), σ₁ the saturated ground's (θ = 1, f = 0); f
decreases smoothly and monotonically between, so wetter ground is weaker and the same impact digs a
deeper crater (:mod:`erosim.erosion.splash`).

Modelling choice: the seed's eq. (15) is legible only as a piecewise law with σ₀ at θ = 0, σ₁ at
θ = 1 and an exponential f between; its f is garbled in the only copy. The f above is SPEC SP-2's
reconstruction (the default): the only smooth exponential in the seed's remnants
(``21()1efe`` → (e^{(1−θ)²} − 1)/(e − 1)) that takes the two end values. f′(1) = 0, so the strength
flattens out as the ground nears saturation and drops fastest on first wetting.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import model_validator

from erosim.core.config import Section, param
from erosim.core.errors import ConfigError


class WetStrengthParams(Section):
    """σ₀ (dry) and σ₁ (saturated) yield strengths; σ₁ ≤ σ₀."""

    sigma_dry: float = param(2.0e4, gt=0, unit="Pa", doc="yield strength σ₀ of dry ground (θ = 0)")
    sigma_wet: float = param(4.0e3, gt=0, unit="Pa", doc="yield strength σ₁ of saturated ground (θ = 1), ≤ σ₀")

    @model_validator(mode="after")
    def _order(self) -> WetStrengthParams:
        if self.sigma_wet > self.sigma_dry:
            raise ConfigError(
                f"ground.sigma_wet = {self.sigma_wet:g} Pa is above ground.sigma_dry = {self.sigma_dry:g} Pa, but "
                "wet ground is the weaker; give sigma_wet ≤ sigma_dry."
            )
        return self


def weakening(theta):
    """f(θ) = (e^{(1−θ)²} − 1)/(e − 1): 1 when dry, 0 when saturated, decreasing between."""
    t = np.clip(np.asarray(theta, dtype=np.float64), 0.0, 1.0)
    return np.expm1((1.0 - t) ** 2) / (math.e - 1.0)


def strength(theta, sigma_dry: float, sigma_wet: float):
    """σ_s(θ) = σ₁ + (σ₀ − σ₁) f(θ) (Pa) for saturations θ (scalar or array)."""
    return sigma_wet + (sigma_dry - sigma_wet) * weakening(theta)
