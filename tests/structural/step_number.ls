/* The built-in step number (docs/structural.md, section 7): 1 in the first
   step. The apex marks each internode with its step, and branches from
   step 4 on. The homomorphism sees step = the number of steps derived. */
derivation length: 5

productions:
A : step <= 3 -> F(step)A
A : step > 3 -> F(step)[+B]A

homomorphism:
B -> B(step)

axiom:
A
