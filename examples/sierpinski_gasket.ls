/* Sierpinski gasket (edge rewriting), ABOP figure 1.10a (p. 11).
   n = 6, delta = 60 degrees.
   The book's edges Fl and Fr are written L and R; the homomorphism turns
   both into a drawn edge F after the last step. */
view: angle = 60
view: width = 0.21
view: palette = #4a148c
derivation length: 6
define: delta = 60

productions:
L -> R+L+R
R -> L-R-L

homomorphism:
L -> F
R -> F

axiom:
R
