/* Quadratic Koch island (Mandelbrot), ABOP figure 1.7a (p. 9).
   n = 2, delta = 90 degrees. */
view: angle = 90
view: width = 0.21
view: palette = #0d47a1
derivation length: 2
define: delta = 90

productions:
F -> F+FF-FF-F-F+F+FF-F-F+F+FF+FF-F

axiom:
F-F-F-F
