/* Bench workload (context-sensitive, ignore:): the rules of ABOP figure
   1.31a (Hogeweg and Hesper) applied for a few steps to a huge bracketed
   axiom given with --axiom (made by signal_axiom.ls). Contexts skip + - F. */
define: delta = 22.5
ignore: +-F

productions:
0 < 0 > 0 -> 0
0 < 0 > 1 -> 1[+F1F1]
0 < 1 > 0 -> 1
0 < 1 > 1 -> 1
1 < 0 > 0 -> 0
1 < 0 > 1 -> 1F1
1 < 1 > 0 -> 0
1 < 1 > 1 -> 0
+ -> -
- -> +

axiom:
F1F1F1
