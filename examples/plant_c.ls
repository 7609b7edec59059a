/* Bracketed OL-system plant, ABOP figure 1.24c (p. 25).
   n = 4, delta = 22.5 degrees. */
view: angle = 22.5
view: width = 0.18
view: palette = #33691e
derivation length: 4
define: delta = 22.5

productions:
F -> FF-[-F+F+F]+[+F-F-F]

axiom:
F
