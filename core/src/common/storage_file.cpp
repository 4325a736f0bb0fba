#include "common/storage_file.h"

#include "picoscan/error.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <vector>

namespace picoscan::detail {

namespace {

constexpr std::uintmax_t kLargestStorageFile = 64u << 20;  // calibration and manifests are small
constexpr int kDeepestNesting = 64;  // no PicoScan file nests more than 4 levels

std::string at_line(int line) { return "line " + std::to_string(line) + ": "; }

// An integer literal (decimal or 0x hex) that OpenCV would store in a 32-bit int.
bool integer_overflows_int32(const std::string& token) {
    size_t at = (token[0] == '+' || token[0] == '-') ? 1 : 0;
    int base = 10;
    if (token.size() > at + 2 && token[at] == '0' && (token[at + 1] == 'x' || token[at + 1] == 'X')) {
        base = 16;
        at += 2;
    }
    if (at >= token.size()) return false;
    for (size_t i = at; i < token.size(); ++i)
        if (base == 10 ? !std::isdigit(static_cast<unsigned char>(token[i]))
                       : !std::isxdigit(static_cast<unsigned char>(token[i])))
            return false;  // not an integer: OpenCV reads it as a real or a string
    while (at + 1 < token.size() && token[at] == '0') ++at;
    if (token.size() - at > 10) return true;
    return std::stoll(token.substr(at), nullptr, base) > 2147483647LL;
}

// OpenCV's FileStorage parsers recurse once per nesting level (a 200 KB file 100 000
// levels deep overflows the stack) and wrap integers to 32 bits silently. One linear pass
// rejects both before OpenCV sees the text: nesting counts flow brackets, YAML indentation
// levels and "- " sequence markers, or XML elements; quoted text and comments are skipped.
void screen_structure(const std::string& text, char first, const std::string& path, const std::string& what) {
    const bool xml = first == '<', yaml = first != '{' && first != '<';
    int line = 1, flow_depth = 0, element_depth = 0;
    size_t sequence_markers = 0;  // "- " on the current YAML line
    std::vector<size_t> indents;  // YAML block levels open at this line
    std::string token;
    auto check_token = [&] {
        if (!token.empty() && integer_overflows_int32(token))
            throw Error(path, what + ": " + at_line(line) + "the whole number " + token.substr(0, 32) +
                                  " does not fit in 32 bits");
        token.clear();
    };
    auto check_depth = [&](size_t depth) {
        if (depth > size_t(kDeepestNesting))
            throw Error(path, what + ": " + at_line(line) + "nested more than " + std::to_string(kDeepestNesting) +
                                  " levels deep");
    };
    bool line_start = true;
    for (size_t at = 0; at < text.size(); ++at) {
        const char c = text[at];
        if (yaml && line_start && flow_depth == 0) {
            line_start = false;
            size_t indent = at;
            while (indent < text.size() && (text[indent] == ' ' || text[indent] == '\t')) ++indent;
            if (indent < text.size() && text[indent] != '\n' && text[indent] != '\r' && text[indent] != '#') {
                while (!indents.empty() && indents.back() > indent - at) indents.pop_back();
                if (indents.empty() || indents.back() < indent - at) indents.push_back(indent - at);
                check_depth(indents.size());
            }
        }
        if (c == '\n') {
            check_token();
            ++line;
            line_start = true;
            sequence_markers = 0;
            continue;
        }
        // Each "- " opens a sequence one level deeper, also after a key ("key: - - - x").
        if (yaml && c == '-' && token.empty() &&
            (at + 1 == text.size() || text[at + 1] == ' ' || text[at + 1] == '\t' || text[at + 1] == '\n' ||
             text[at + 1] == '\r')) {
            check_depth(indents.size() + size_t(flow_depth) + ++sequence_markers);
            continue;
        }
        if (xml && c == '<') {
            check_token();
            // Skips the whole tag; comments and <? ?> may hold '>' and do not nest.
            const bool comment = text.compare(at, 4, "<!--") == 0;
            const size_t end = comment ? text.find("-->", at) : text.find('>', at);
            const size_t stop = end == std::string::npos ? text.size() : end + (comment ? 3 : 1);
            const bool closing = at + 1 < text.size() && text[at + 1] == '/';
            const bool special = at + 1 < text.size() && (text[at + 1] == '?' || text[at + 1] == '!');
            const bool empty_element = end != std::string::npos && !comment && end > at && text[end - 1] == '/';
            if (closing) element_depth = std::max(0, element_depth - 1);
            else if (!special && !empty_element) check_depth(size_t(++element_depth));
            for (; at + 1 < stop; ++at) line += text[at + 1] == '\n';
            continue;
        }
        if (!xml && (c == '"' || (yaml && c == '\'' && token.empty()))) {
            // A quoted string ends at its closing quote or, as OpenCV requires, at the line's end.
            check_token();
            for (++at; at < text.size() && text[at] != c && text[at] != '\n'; ++at)
                if (c == '"' && text[at] == '\\' && at + 1 < text.size() && text[at + 1] != '\n') ++at;
            if (at < text.size() && text[at] == '\n') --at;
            continue;
        }
        if (yaml && c == '#' && token.empty()) {
            while (at + 1 < text.size() && text[at + 1] != '\n') ++at;
            continue;
        }
        if (!xml && (c == '[' || c == '{')) check_depth(size_t(++flow_depth) + indents.size() + sequence_markers);
        else if (!xml && (c == ']' || c == '}')) flow_depth = std::max(0, flow_depth - 1);
        if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '+' || c == '-') {
            token += c;
        } else {
            check_token();
        }
    }
    check_token();
}

// OpenCV's YAML parser loops forever on some documents whose root is not a mapping (an
// indented "- a" followed by less indented items: found by fuzz_scene). Every file the project
// reads is a mapping, so its first content line must be a key at the start of the line.
void check_yaml_root_is_mapping(const std::string& text, const std::string& path, const std::string& what) {
    int line = 0;
    for (size_t start = 0; start < text.size();) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        ++line;
        const std::string row = text.substr(start, end - start);
        start = end + 1;
        const size_t content = row.find_first_not_of(" \t\r");
        // Only an exact "---" marks a document start: OpenCV loops forever on "----&\n----".
        const bool document_start = row.find_last_not_of(" \t\r") == 2 && row.rfind("---", 0) == 0;
        if (content == std::string::npos || row[content] == '#' || row.rfind("%YAML", 0) == 0 || document_start)
            continue;
        const bool key = content == 0 && (std::isalpha(static_cast<unsigned char>(row[0])) || row[0] == '_') &&
                         row.find(':') != std::string::npos;
        if (!key)
            throw Error(path, what + ": " + at_line(line) + "a YAML file must begin with a key at the start of the "
                                  "line (\"name: value\"), not \"" + row.substr(content, 20) + "\"");
        return;
    }
}

std::string trimmed(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) return "";
    return text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
}

}  // namespace

std::string read_text_file(const std::string& path, const std::string& what) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) throw Error(path, what + " not found");
    if (std::filesystem::file_size(path, error) > kLargestStorageFile) throw Error(path, what + " is larger than 64 MB");
    std::ifstream stream(path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
    if (stream.bad()) throw Error(path, "cannot read the " + what);
    if (trimmed(text).empty()) throw Error(path, what + " is empty");
    // OpenCV's YAML parser can loop forever on control bytes; these files are plain ASCII.
    for (size_t offset = 0; offset < text.size(); ++offset) {
        const unsigned char byte = static_cast<unsigned char>(text[offset]);
        if ((byte < 0x20 && byte != '\n' && byte != '\r' && byte != '\t') || byte > 0x7e)
            throw Error(path, what + " is not a plain ASCII text file (byte " + std::to_string(int(byte)) +
                                  " at offset " + std::to_string(offset) + ")");
    }
    return text;
}

cv::FileStorage open_storage_file(const std::string& path, const std::string& what, StorageFormats formats) {
    std::string text = read_text_file(path, what);
    for (size_t line = text.find('\n'); line != std::string::npos; line = text.find('\n', line + 1))
        if (line + 1 < text.size() && text[line + 1] == '%')
            throw Error(path, what + ": a '%' directive is only allowed on the first line");
    const std::string content = trimmed(text);
    const char first = content.front();
    if (formats == StorageFormats::JsonOnly && first != '{') throw Error(path, what + " must be a JSON object");
    screen_structure(text, first, path, what);
    if (first == '<') {
        // OpenCV's XML parser reads past the end of a truncated tag; a complete file ends
        // with its root element closed.
        const std::string closing = "</opencv_storage>";
        if (content.size() < closing.size() || content.compare(content.size() - closing.size(), closing.size(), closing) != 0)
            throw Error(path, what + " is not a complete OpenCV XML file (no closing </opencv_storage>)");
    } else if (first != '{') {
        check_yaml_root_is_mapping(text, path, what);
        if (content.rfind("%YAML", 0) != 0) text = "%YAML:1.0\n" + text;
    }

    const std::string format_name = first == '{' ? "JSON" : first == '<' ? "XML" : "YAML";
    cv::FileStorage storage;
    try {
        const int format = first == '{' ? cv::FileStorage::FORMAT_JSON
                         : first == '<' ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML;
        if (!storage.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | format))
            throw Error(path, "cannot parse the " + what + " as " + format_name);
    } catch (const Error&) {
        throw;
    } catch (const cv::Exception& failure) {
        throw Error(path, "cannot parse the " + what + " as " + format_name + " (" + failure.err + ")");
    } catch (const std::exception& failure) {
        throw Error(path, "cannot parse the " + what + " as " + format_name + " (" + failure.what() + ")");
    }
    return storage;
}

}  // namespace picoscan::detail
