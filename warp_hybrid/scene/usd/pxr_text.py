"""pxr's error text made readable: its message kept, its C++ wrapping dropped.

A ``Tf.ErrorException`` reads ``Error in 'pxrInternal_v0_26_11__pxrReserved__::UsdStage::Open'
at line 1287 in file stage.cpp : 'Failed to open layer @x.usda@'`` per error; what
matters is the quoted message at the end.  ``strip_namespaces`` removes the versioned
namespace prefix wherever it appears (it also leaks into the messages themselves).
"""

from __future__ import annotations

import re

_MANGLED = re.compile(r"pxrInternal_v\d+_\d+(?:_\d+)*__pxrReserved__::")
_TF_ERROR = re.compile(r"Error in '[^']*' at line \d+ in file [^\n]*? : '(.*?)'\s*(?=\n\s*Error in |\Z)", re.DOTALL)


def strip_namespaces(text: str) -> str:
    """``text`` without pxr's versioned ``pxrInternal_v..__pxrReserved__::`` prefixes."""
    return _MANGLED.sub("", text)


def tf_message(error: BaseException | str) -> str:
    """The first message of a pxr error (``Tf.ErrorException`` or its text), without
    its C++ location and mangled namespaces; the whole text when it has no such form."""
    text = strip_namespaces(str(error))
    found = _TF_ERROR.findall(text)
    return (found[0] if found else text).strip()
