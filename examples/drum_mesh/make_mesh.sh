#!/bin/sh
# Writes drum.stl: the drum of He 2018 sec. 3.2.2 (100 mm diameter, 100 mm long, axis along y from
# y = 0 to y = 0.1, closed ends), facet normals pointing into the drum, 64 facets around.
cd "$(dirname "$0")" && exec python3 ../../tools/stl_shapes.py cylinder --center 0 0.05 0 --axis 0 1 0 \
    --radius 0.05 --length 0.1 --segments 64 -o drum.stl
