/* Three-dimensional extension of Hilbert's space-filling curve,
   ABOP figure 1.19 (p. 20).  n = 2, delta = 90 degrees.
   & ^ pitch, \ / roll, | turn around. */
view: angle = 90
view: width = 0.08
view: palette = #0d47a1
view: direction = 30 25
derivation length: 2
define: delta = 90

productions:
A -> B-F+CFC+F-D&F^D-F+&&CFC+F+B//
B -> A&F^CFB^F^D^^-F-D^|F^B|FC^F^A//
C -> |D^|F^B-F+C^F^A&&FA&F^C+F+B^F^D//
D -> |CFB-F+B|FA&F^A&&FB-F+B|FC//

axiom:
A
