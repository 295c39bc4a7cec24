# Writes OUTPUT, a C++ source holding the bytes of INPUT as an array, its size
# and its SHA-256, in namespace scanbench::embedded:
#   extern const unsigned char k<SYMBOL>Bytes[]; extern const unsigned long k<SYMBOL>Size;
#   extern const char k<SYMBOL>Sha256[]; extern const char k<SYMBOL>Source[] (= SOURCE_NAME)
# Invoked by an add_custom_command that depends on INPUT, so a new model regenerates it.
file(READ "${INPUT}" hex HEX)
file(SHA256 "${INPUT}" sha)
file(SIZE "${INPUT}" size)
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
# One line per 32 bytes keeps the source readable by editors and compilers alike.
string(REGEX REPLACE "((0x..,){32})" "\\1\n" bytes "${bytes}")
file(WRITE "${OUTPUT}" "// Generated from ${SOURCE_NAME} by cmake/EmbedBinaryFile.cmake: do not edit.\n"
  "namespace scanbench::embedded {\n"
  "extern const unsigned char k${SYMBOL}Bytes[] = {\n${bytes}\n};\n"
  "extern const unsigned long k${SYMBOL}Size = ${size};\n"
  "extern const char k${SYMBOL}Sha256[] = \"${sha}\";\n"
  "extern const char k${SYMBOL}Source[] = \"${SOURCE_NAME}\";\n"
  "}  // namespace scanbench::embedded\n")
