"""The interactive viewer: a local web page where the cursor (or the webcam) is the gaze.

``warp-hybrid view SCENE`` serves the page (``static/``) and a WebSocket (``server``);
a render thread (``render_thread``) drives the adaptive loop continuously and publishes
the newest frame (``frames``) to every connected page; the messages both ways are
defined once in ``protocol``.
"""
