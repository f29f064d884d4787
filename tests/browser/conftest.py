"""The site in a real browser: collected only when ``GEOMECH_SITE`` names a built site (``make test-browser`` builds
it and sets it), so ``make test`` does not need Chromium."""

import os

if not os.environ.get("GEOMECH_SITE"):
    collect_ignore_glob = ["test_*.py"]
