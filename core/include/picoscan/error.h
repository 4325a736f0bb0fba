// The one error type of the PicoScan core.
// Every failure names what it concerns (a file, a frame, a parameter) and what is wrong;
// front ends print what() on one line and exit non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace picoscan {

class Error : public std::runtime_error {
public:
    // subject: the file, frame or parameter concerned; problem: what is wrong with it.
    Error(const std::string& subject, const std::string& problem)
        : std::runtime_error(subject.empty() ? problem : subject + ": " + problem), subject_(subject) {}
    const std::string& subject() const { return subject_; }

private:
    std::string subject_;
};

}  // namespace picoscan
