/* Signal propagation in a 1L-system, ABOP section 1.8 (p. 30):
   the signal b moves one cell to the right per step:
   baaaaaa => abaaaaa => aabaaaa => aaabaaa => ... */
view: step = 1   /* a and b are not turtle symbols: nothing is drawn */
derivation length: 3

productions:
b < a -> b
b -> a

axiom:
baaaaaa
