# Embeds a file as a C array (the monitor's page):
#   cmake -DINPUT=<file> -DOUTPUT=<file.c> -DSYMBOL=<c identifier> -P pf_embed.cmake
# gives `const unsigned char SYMBOL[]` (NUL-terminated) and `const unsigned long SYMBOL_size`
# (without the NUL).
file(READ "${INPUT}" hex HEX)
string(LENGTH "${hex}" hex_length)
math(EXPR size "${hex_length} / 2")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE "${OUTPUT}"
     "/* Generated from ${INPUT} by cmake/pf_embed.cmake; do not edit. */\n"
     "const unsigned char ${SYMBOL}[] = {${bytes}0x00};\n"
     "const unsigned long ${SYMBOL}_size = ${size}ul;\n")
