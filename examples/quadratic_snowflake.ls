/* Quadratic modification of the snowflake curve, ABOP figure 1.7b (p. 9).
   n = 4, delta = 90 degrees. */
view: angle = 90
view: width = 0.27
view: palette = #0d47a1
derivation length: 4
define: delta = 90

productions:
F -> F+F-F-F+F

axiom:
-F
