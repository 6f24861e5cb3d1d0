"""The frame-time budget controller: sizes the traced focus window so a target frame rate holds.

``BudgetController.plan(gaze)`` before a frame answers a ``WindowPlan`` (the window's
area, what it should cost, the deadline by which tracing must stop);
``BudgetController.observe(FrameCost)`` after it learns from what the frame measured.
It predicts the trace cost of a window at any gaze from a per-tile cost map learnt
online (model.py), and controls the size after Unreal Engine's dynamic-resolution
heuristic (controller.py).  Pure Python and numpy; it reads no clock, so a cost model
(``SyntheticCost``) can stand in for the renderer.
"""

from .controller import BudgetController, largest_fitting
from .model import RAY_TYPES
from .settings import ControllerSettings, FrameCost, WindowPlan
from .synthetic import Spike, SyntheticCost, fps_budget, run_loop
from .tiles import TileGrid

__all__ = [
    "RAY_TYPES",
    "BudgetController",
    "ControllerSettings",
    "FrameCost",
    "Spike",
    "SyntheticCost",
    "TileGrid",
    "WindowPlan",
    "fps_budget",
    "largest_fitting",
    "run_loop",
]
