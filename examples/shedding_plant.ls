/* A plant that sheds its old branches with the cut symbol %
   (docs/structural.md, section 5). Each lateral branch starts with an
   abscission zone S(age); at age 2 the zone becomes %, and in the next step
   % cuts itself and the rest of its branch: the brackets stay, empty. */
view: angle = 40
view: palette = #795548 #2e7d32
derivation length: 5

productions:
A -> I[+S(0)FL]I[-S(0)FL]A
S(a) : a < 2 -> S(a+1)
S(a) : a >= 2 -> %
F -> FF
I -> FI

axiom:
A
