"""The OpenCV webcam gaze estimator: Haar-initialised sub-pixel face tracking, dark-centroid
pupils, a 9-point quadratic calibration and One Euro smoothing, behind ``WebcamSource``.

Modules: ``capture`` (camera or video frames with timestamps), ``face`` (detection and
tracking), ``eyes`` (pupils and the feature), ``calibration`` (fit, JSON), ``estimator``
(the per-frame pipeline), ``source`` (the threaded ``GazeSource``), ``commands`` (the
``gaze calibrate``/``gaze record`` commands) and ``synthetic`` (test videos with a known gaze).
"""
