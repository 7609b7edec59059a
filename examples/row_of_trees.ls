/* Parametric "row of trees", ABOP section 1.10.3 (p. 48, figure 1.37b):
   a Koch-like curve whose edges are split unevenly (ratio p : q); the
   second parameter t delays the growth of the newer segments.
   delta = 86 degrees.  The book's condition t=0 is written t == 0. */
view: angle = 86
view: twist = -90   /* the book's curve runs to the right */
view: width = 0.005
view: palette = #33691e
derivation length: 10
define: delta = 86
define: c = 1
define: p = 0.3
define: q = c - p
define: h = (p*q)^0.5

productions:
F(x,t) : t == 0 -> F(x*p,2)+F(x*h,1)--F(x*h,1)+F(x*q,0)
F(x,t) : t > 0 -> F(x,t-1)

axiom:
F(1,0)
