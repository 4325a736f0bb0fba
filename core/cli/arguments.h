// The command line of one picoscan command: input files first, then "--key value" options
// and "--flag" switches. Every value is checked when it is read; unknown options are errors.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <set>
#include <string>
#include <vector>

namespace picoscan::cli {

// How a command reads its command line.
struct ArgumentRules {
    std::set<std::string> flags;         // options without a value
    std::set<std::string> list_options;  // options that take several values (--captures A B C)
    bool takes_inputs = false;           // input files before the options (clean, stitch, mesh)
};

class Arguments {
public:
    // Parses argv[first..argc).
    Arguments(int argc, char** argv, int first, const ArgumentRules& rules);

    const std::vector<std::string>& inputs() const { return inputs_; }
    bool has(const std::string& key) const { return values_.count(key) > 0; }
    bool flag(const std::string& key) const;
    std::string text(const std::string& key, const std::string& fallback = "") const;
    std::string required(const std::string& key) const;
    // Every value given for an option that takes several.
    std::vector<std::string> list(const std::string& key) const;
    // The values of each occurrence of an option that takes several, apart:
    // --then A B --then C gives {{A, B}, {C}}.
    std::vector<std::vector<std::string>> occurrences(const std::string& key) const;
    double number(const std::string& key, double fallback) const;
    int integer(const std::string& key, int fallback) const;
    cv::Size size(const std::string& key) const;                          // WIDTHxHEIGHT
    std::vector<double> numbers(const std::string& key, size_t count) const;  // A,B,C
    // Unknown options are mistakes (a typo would otherwise be silently ignored).
    void reject_unknown() const;

private:
    void require_output_folders() const;

    std::vector<std::string> inputs_;
    std::map<std::string, std::vector<std::string>> values_;  // every value of every option
    std::map<std::string, std::vector<size_t>> occurrence_starts_;  // where each occurrence's values begin
    std::set<std::string> list_options_;
    mutable std::set<std::string> used_;
};

}  // namespace picoscan::cli
