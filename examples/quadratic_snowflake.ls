/* Quadratic modification of the snowflake curve, ABOP figure 1.7b (p. 9).
   n = 4, delta = 90 degrees. */
derivation length: 4
define: delta = 90

productions:
F -> F+F-F-F+F

axiom:
-F
