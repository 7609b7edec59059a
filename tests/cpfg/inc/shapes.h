/* included by preprocessor.l: macros and a production */
#ifndef SHAPES_H
#define SHAPES_H
#define SEG(len) F(len)
#define TWIG(a, len) [+(a)SEG(len)]
#endif
