/* Bench workload (D0L): dragon curve, ABOP figure 1.10b, node-rewriting
   form. The string roughly doubles each step. */
define: delta = 90

productions:
l -> l+rF+
r -> -Fl-r

axiom:
Fl
