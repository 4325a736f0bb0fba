#include "common/third_party_output.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <mutex>

namespace picoscan::detail {

namespace {

constexpr size_t kLongestText = 400;

std::mutex capture_mutex;
int active_captures = 0;
int saved_stderr = -1;  // the real stderr while captures are active
int capture_file = -1;  // where fd 2 points meanwhile

void flush_stderr() {
    std::fflush(stderr);
    std::cerr.flush();
}

}  // namespace

ThirdPartyOutput::ThirdPartyOutput() : exceptions_(std::uncaught_exceptions()) {
    const std::lock_guard<std::mutex> lock(capture_mutex);
    if (active_captures == 0) {
        flush_stderr();
        FILE* file = std::tmpfile();  // unlinked: nothing is left behind, even on a signal
        const int copy = file ? ::dup(STDERR_FILENO) : -1;
        if (copy < 0) {  // no capture: the text goes where it always went
            if (file) std::fclose(file);
            ++active_captures;
            return;
        }
        capture_file = ::dup(::fileno(file));
        std::fclose(file);
        saved_stderr = copy;
        ::dup2(capture_file, STDERR_FILENO);
    }
    ++active_captures;
    start_ = capture_file >= 0 ? long(::lseek(capture_file, 0, SEEK_END)) : 0;
}

ThirdPartyOutput::~ThirdPartyOutput() {
    const bool unwinding = std::uncaught_exceptions() > exceptions_;
    const std::string untaken = taken_ || unwinding ? "" : raw();
    const std::lock_guard<std::mutex> lock(capture_mutex);
    if (!untaken.empty() && saved_stderr >= 0)
        if (::write(saved_stderr, untaken.data(), untaken.size()) < 0) {
            // nowhere left to report it
        }
    if (--active_captures > 0 || capture_file < 0) return;
    flush_stderr();
    ::dup2(saved_stderr, STDERR_FILENO);
    ::close(saved_stderr);
    ::close(capture_file);
    saved_stderr = capture_file = -1;
}

std::string ThirdPartyOutput::raw() const {
    const std::lock_guard<std::mutex> lock(capture_mutex);
    if (capture_file < 0) return "";
    flush_stderr();
    std::string bytes;
    char buffer[4096];
    for (off_t at = start_;;) {
        const ssize_t count = ::pread(capture_file, buffer, sizeof buffer, at);
        if (count <= 0 || bytes.size() > (1u << 20)) break;
        bytes.append(buffer, size_t(count));
        at += count;
    }
    return bytes;
}

std::string ThirdPartyOutput::text() {
    taken_ = true;
    std::string raw = this->raw();
    if (raw.size() > 4 * kLongestText) raw.resize(4 * kLongestText);
    std::string line;
    bool gap = false;
    for (const char c : raw) {
        if (c == '\n' || c == '\r') {
            gap = !line.empty();
            continue;
        }
        if (gap) line += "; ";
        gap = false;
        line += (c >= 32 && c < 127) || c == '\t' ? c : '?';
    }
    if (line.size() > kLongestText) line = line.substr(0, kLongestText - 3) + "...";
    return line;
}

std::string attached(const std::string& third_party_text, const std::string& who) {
    return third_party_text.empty() ? "" : " (" + who + " said: " + third_party_text + ")";
}

}  // namespace picoscan::detail
