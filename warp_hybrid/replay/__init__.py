"""Replaying a recorded gaze trace over a scene at a fixed frame rate, and its outputs.

``video`` (H.264 MP4 through PyAV, encoded off the render thread), ``stats_csv`` (the
per-frame statistics CSV), ``summary`` (the run's figures), ``progress`` (the terminal
progress bar), ``overlay`` (the focus window and gaze drawn on a frame) and ``partial``
(files written under a temporary name and renamed into place on close).
"""
