/* Von Koch snowflake, the construction of ABOP figure 1.1 (p. 2) written as
   an L-system (initiator = triangle, generator = F+F--F+F).
   delta = 60 degrees.  After n steps the string has exactly 7*4^n symbols. */
view: angle = 60
view: width = 0.31
view: palette = #01579b
derivation length: 4
define: delta = 60

productions:
F -> F+F--F+F

axiom:
F--F--F
