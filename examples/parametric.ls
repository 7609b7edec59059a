/* Parametric example, ABOP section 1.10.1 (p. 43):
   B(2)A(4,4) => B(1)B(4)A(1,0) => B(0)B(3)A(2,1) => CB(2)A(4,3) => CB(1)A(8,7)
   The homomorphism (not in the book) replaces C, after the last step,
   by an edge of length R. */
view: width = 0.05
derivation length: 4
define: R = 1.456
seed: 42

productions:
A(x,y) : y <= 3 -> A(x*2, x+y)
A(x,y) : y > 3 -> B(x)A(x/y,0)
B(x) : x < 1 -> C
B(x) : x >= 1 -> B(x-1)

homomorphism:
C -> F(R)

axiom:
B(2)A(4,4)
