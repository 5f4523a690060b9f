#!/bin/bash
# Build the documentation site and photograph two pages in a real headless browser (Debian's
# chromium: apt-get install chromium): the front page and the demo page of flying-spaghetti-2d
# with the pictures its run draws.  Writes benchmarks/docs_site/{front-page,demo-page}.png.
set -euo pipefail
cd "$(dirname "$0")/../.."
here=benchmarks/docs_site
.venv/bin/python docs/pictures.py flying-spaghetti-2d
.venv/bin/python -m sphinx -E -W -q -b html docs docs/_build/html
shot() { chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --window-size="$2" \
         --screenshot="$here/$3" "file://$PWD/docs/_build/html/$1" 2>/dev/null; }
shot index.html 1280,1000 front-page.png
shot demos/flying_spaghetti_2d.html 1280,3200 demo-page.png
ls -l "$here"/*.png
