"""The one error type the gaze package raises on purpose."""

from __future__ import annotations


class GazeError(Exception):
    """Bad input or a missing device: the message names the file or device, then the problem."""

    def __init__(self, where: str, problem: str) -> None:
        self.where = str(where)
        self.problem = problem
        super().__init__(f"{self.where}: {problem}")
