/* Bench workload (D0L): Von Koch snowflake, ABOP figure 1.1.
   After n steps the string has exactly 7*4^n modules. */
define: delta = 60

productions:
F -> F+F--F+F

axiom:
F--F--F
