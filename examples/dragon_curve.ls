/* Dragon curve, ABOP figure 1.10b (p. 11).  n = 10, delta = 90 degrees.
   The book rewrites edges: Fl -> Fl+Fr+, Fr -> -Fl-Fr.  Here the edge labels
   are separate (non-drawing) symbols l and r, the usual node-rewriting form
   that draws the same curve. */
view: angle = 90
view: width = 0.16
view: palette = #b71c1c
derivation length: 10
define: delta = 90

productions:
l -> l+rF+
r -> -Fl-r

axiom:
Fl
