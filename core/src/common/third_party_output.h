// What third-party libraries print on stderr (libpng through OpenCV's decoders, OpenCV's own
// log, CGAL), held back so that an error is one line from PicoScan with their text attached.
#pragma once

#include <string>

namespace picoscan::detail {

// While at least one capture lives, the process's stderr (file descriptor 2) goes to an
// unlinked temporary file. Captures may overlap (decoding threads), so each one reads what
// was printed since it began, which may include text of a concurrent call. Hold one only
// around the third-party call itself: PicoScan's own messages must not be inside it.
class ThirdPartyOutput {
public:
    ThirdPartyOutput();
    ~ThirdPartyOutput();
    ThirdPartyOutput(const ThirdPartyOutput&) = delete;
    ThirdPartyOutput& operator=(const ThirdPartyOutput&) = delete;

    // What was printed since this capture began, on one line ("a; b"), at most 400
    // characters; empty when nothing was. The text is then PicoScan's to report.
    std::string text();
    // Drops what was printed (warnings about an input that was read all the same).
    void discard() { taken_ = true; }
    // Otherwise, what was printed is passed on to stderr when the capture ends, so that
    // nothing another part of the process printed meanwhile is lost; but not when the capture
    // ends by an exception, whose message is reported instead (CGAL's exceptions carry what
    // its error handler prints).

private:
    std::string raw() const;

    long start_ = 0;  // offset in the shared capture file when this capture began
    bool taken_ = false;
    int exceptions_ = 0;  // std::uncaught_exceptions() when the capture began
};

// " (the decoder said: TEXT)" or "" for an empty text: how a message carries it.
std::string attached(const std::string& third_party_text, const std::string& who);

}  // namespace picoscan::detail
