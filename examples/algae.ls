/* Lindenmayer's original L-system for the growth of algae (Anabaena),
   ABOP section 1.2, figure 1.3 (p. 4).  The string lengths follow the
   Fibonacci numbers 1, 2, 3, 5, 8, 13, ... */
view: step = 1   /* a and b are not turtle symbols: nothing is drawn */
derivation length: 5

productions:
a -> ab
b -> a

axiom:
a
