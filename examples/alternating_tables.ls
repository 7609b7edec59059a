/* Alternating tables (docs/structural.md, section 6): two wet years, then
   a dry one, again and again. Group 0 holds what happens every year; the
   step's group comes first and group 0 is the fallback. In a wet year the
   apex branches and internodes grow (group 0); in a dry year the apex only
   leaves a ring R, and I -> I keeps internodes from growing. */
view: angle = 30
derivation length: 6
groups: 1 1 2

productions:
I -> FI

productions 1:
A -> I[+A][-A]A

productions 2:
A -> RA
I -> I

axiom:
A
