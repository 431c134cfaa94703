# Writes a C++ source that defines `const char* <namespace>::<name>()` returning the text of <file>.
# Usage: cmake -DINPUT=file -DOUTPUT=out.cpp -DNAME=sym -DNAMESPACE=ns -P EmbedText.cmake
file(READ ${INPUT} _text)
file(WRITE ${OUTPUT} "// Generated from ${INPUT}; do not edit.\nnamespace ${NAMESPACE} {\nconst char* ${NAME}() {\n  return R\"PAINTLAB_TEXT(${_text})PAINTLAB_TEXT\";\n}\n}  // namespace ${NAMESPACE}\n")
