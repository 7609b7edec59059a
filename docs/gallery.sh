#!/bin/sh
# Regenerate the README gallery: docs/gallery/*.png from examples/*.ls.
# Run from the repository root:  sh docs/gallery.sh
# Each picture is one pipe, as README shows it:
#   lsgen examples/NAME.ls | lsgen-turtle --ls examples/NAME.ls --size 400 -o docs/gallery/NAME.png
set -eu
cargo build --release --quiet
bin=target/release
out=docs/gallery
mkdir -p "$out"
for name in plant_a plant_b plant_c plant_d plant_e plant_f bush \
            context_plant_a context_plant_b context_plant_c context_plant_d context_plant_e \
            ternary_tree koch_island dragon_curve hilbert3d stochastic_row; do
    "$bin/lsgen" "examples/$name.ls" |
        "$bin/lsgen-turtle" --ls "examples/$name.ls" --size 400 -o "$out/$name.png"
done
# cpfg's language, with cpfg's view file and colour map.
"$bin/lsgen" examples/cpfg/weeping.l |
    "$bin/lsgen-turtle" --cpfg-view examples/cpfg/weeping.v \
        --colormap examples/cpfg/weeping.map --size 400 -o "$out/weeping.png"
# cpfg's turtle queries: lsgen needs the view file too.
"$bin/lsgen" examples/cpfg/clipped.l --cpfg-view examples/cpfg/clipped.v |
    "$bin/lsgen-turtle" --cpfg-view examples/cpfg/clipped.v \
        --colormap examples/cpfg/clipped.map --size 400 -o "$out/clipped.png"
