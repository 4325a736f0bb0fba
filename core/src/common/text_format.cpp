#include "common/text_format.h"

#include <cstdarg>
#include <cstdio>

namespace picoscan {

std::string format(const char* pattern, ...) {
    char text[4096];
    va_list arguments;
    va_start(arguments, pattern);
    std::vsnprintf(text, sizeof text, pattern, arguments);
    va_end(arguments);
    return text;
}

}  // namespace picoscan
