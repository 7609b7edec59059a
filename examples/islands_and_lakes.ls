/* Combination of islands and lakes, ABOP figure 1.8 (p. 9).
   n = 2, delta = 90 degrees.  f moves the turtle without drawing. */
view: angle = 90
view: width = 0.21
view: palette = #0d47a1
derivation length: 2
define: delta = 90

productions:
F -> F+f-FF+F+FF+Ff+FF-f+FF-F-FF-Ff-FFF
f -> ffffff

axiom:
F+F+F+F
