#include "common/storage_text.h"

#include "picoscan/error.h"

#include <opencv2/core/persistence.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace picoscan::detail {

namespace {

constexpr size_t kMaxNumbers = 4096;  // no calibration entry comes close

bool is_key(const std::string& word) {
    if (word.empty() || !(std::isalpha(static_cast<unsigned char>(word[0])) || word[0] == '_')) return false;
    for (char c : word)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
    return true;
}

std::string trim(const std::string& text) {
    const size_t first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos) return "";
    return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

bool parse_number(const std::string& token, double& value) {
    if (token.empty() || token.size() > 64) return false;
    char* end = nullptr;
    errno = 0;
    value = std::strtod(token.c_str(), &end);
    return end == token.c_str() + token.size() && errno == 0 && std::isfinite(value);
}

class Parser {
public:
    Parser(const std::string& path) : path_(path) {}

    [[noreturn]] void fail(int line, const std::string& problem) const {
        throw Error(path_, "line " + std::to_string(line) + ": " + problem);
    }

    // Splits a whitespace/comma separated run of numbers.
    void append_numbers(const std::string& text, int line, std::vector<double>& numbers) const {
        std::string token;
        auto flush = [&] {
            if (token.empty()) return;
            double value;
            if (!parse_number(token, value)) fail(line, "'" + token.substr(0, 32) + "' is not a number");
            if (numbers.size() >= kMaxNumbers) fail(line, "too many numbers");
            numbers.push_back(value);
            token.clear();
        };
        for (char c : text) {
            if (c == ',' || c == ' ' || c == '\t' || c == '\r' || c == '\n') flush();
            else token += c;
        }
        flush();
    }

    void check_matrix(StorageValue& value, const std::string& key) const {
        if (value.rows < 1 || value.cols < 1 || double(value.rows) * value.cols > kMaxNumbers)
            fail(value.line, "'" + key + "' has an implausible matrix size");
        if (value.numbers.size() != size_t(value.rows) * size_t(value.cols))
            fail(value.line, "'" + key + "' must hold rows x cols = " + std::to_string(value.rows * value.cols) +
                                 " numbers, found " + std::to_string(value.numbers.size()));
    }

    int whole_number(const std::string& text, int line, const std::string& what) const {
        double value;
        if (!parse_number(text, value) || value != std::floor(value) || value < 0 || value > 1e6)
            fail(line, what + " must be a whole number");
        return int(value);
    }

    // Joins the lines of a "[ ..." list until one holds ']'. Only each new line is searched,
    // so an unclosed '[' costs linear time, not quadratic.
    template <typename Content>
    static void append_until_closed(std::string& list, const std::vector<std::string>& lines, size_t& index,
                                    const Content& content) {
        bool closed = list.find(']') != std::string::npos;
        while (!closed && index < lines.size()) {
            const std::string next = trim(content(index++));
            closed = next.find(']') != std::string::npos;
            list += " " + next;
        }
    }

    StorageEntries parse_yaml(const std::string& text) const {
        std::vector<std::string> lines;
        std::stringstream stream(text);
        for (std::string line; std::getline(stream, line);) lines.push_back(line);
        StorageEntries entries;
        size_t index = 0;
        auto line_number = [&](size_t at) { return int(at + 1); };
        // Drops comments (no quoted strings hold '#' in these files).
        auto content = [&](size_t at) {
            std::string line = lines[at];
            const size_t hash = line.find('#');
            if (hash != std::string::npos) line.erase(hash);
            return line;
        };
        if (!lines.empty() && trim(content(0)).rfind("%YAML", 0) == 0) ++index;
        while (index < lines.size()) {
            const std::string line = content(index);
            const int number = line_number(index);
            if (trim(line).empty() || trim(line) == "---") {
                ++index;
                continue;
            }
            if (line[0] == ' ' || line[0] == '\t') fail(number, "unexpected indentation");
            const size_t colon = line.find(':');
            if (colon == std::string::npos) fail(number, "expected 'key: value'");
            const std::string key = trim(line.substr(0, colon));
            if (!is_key(key)) fail(number, "'" + key.substr(0, 32) + "' is not a valid key");
            if (entries.count(key)) fail(number, "'" + key + "' appears twice");
            std::string rest = trim(line.substr(colon + 1));
            StorageValue value;
            value.line = number;
            ++index;
            if (rest == "!!opencv-matrix" || rest.empty()) {
                value.kind = StorageValue::Kind::Matrix;
                bool has_rows = false, has_cols = false, has_data = false;
                while (index < lines.size()) {
                    const std::string field_line = content(index);
                    if (trim(field_line).empty()) {
                        ++index;
                        continue;
                    }
                    if (field_line[0] != ' ' && field_line[0] != '\t') break;
                    const int field_number = line_number(index);
                    const size_t field_colon = field_line.find(':');
                    if (field_colon == std::string::npos) fail(field_number, "expected 'rows', 'cols', 'dt' or 'data'");
                    const std::string field = trim(field_line.substr(0, field_colon));
                    const std::string field_value = trim(field_line.substr(field_colon + 1));
                    ++index;
                    if (field == "rows") value.rows = whole_number(field_value, field_number, "rows"), has_rows = true;
                    else if (field == "cols") value.cols = whole_number(field_value, field_number, "cols"), has_cols = true;
                    else if (field == "dt") continue;
                    else if (field == "data") {
                        std::string list = field_value;
                        append_until_closed(list, lines, index, content);
                        if (list.empty() || list.front() != '[' || list.back() != ']')
                            fail(field_number, "'" + key + "' data must be a [ ... ] list");
                        append_numbers(list.substr(1, list.size() - 2), field_number, value.numbers);
                        has_data = true;
                    } else {
                        fail(field_number, "unknown matrix field '" + field.substr(0, 32) + "'");
                    }
                }
                if (!has_rows || !has_cols || !has_data) fail(number, "'" + key + "' needs rows, cols and data");
                check_matrix(value, key);
            } else if (rest.front() == '[') {
                value.kind = StorageValue::Kind::List;
                append_until_closed(rest, lines, index, content);
                if (rest.back() != ']') fail(number, "'" + key + "' list is not closed with ']'");
                append_numbers(rest.substr(1, rest.size() - 2), number, value.numbers);
            } else {
                double parsed;
                if (parse_number(rest, parsed)) {
                    value.kind = StorageValue::Kind::Number;
                    value.numbers.push_back(parsed);
                } else {
                    if (rest.size() >= 2 && (rest.front() == '"' || rest.front() == '\'') && rest.back() == rest.front())
                        rest = rest.substr(1, rest.size() - 2);
                    value.kind = StorageValue::Kind::Word;
                    value.word = rest;
                }
            }
            entries[key] = std::move(value);
        }
        return entries;
    }

    StorageEntries parse_xml(const std::string& text) const {
        size_t at = 0;
        int line = 1;
        auto advance_to = [&](size_t position) {
            for (; at < position && at < text.size(); ++at) line += text[at] == '\n';
        };
        auto skip_space_and_comments = [&] {
            while (true) {
                const size_t next = text.find_first_not_of(" \t\r\n", at);
                advance_to(next == std::string::npos ? text.size() : next);
                if (text.compare(at, 4, "<!--") == 0) {
                    const size_t end = text.find("-->", at);
                    if (end == std::string::npos) fail(line, "unclosed comment");
                    advance_to(end + 3);
                } else if (text.compare(at, 2, "<?") == 0) {
                    const size_t end = text.find("?>", at);
                    if (end == std::string::npos) fail(line, "unclosed <? ?>");
                    advance_to(end + 2);
                } else {
                    return;
                }
            }
        };
        // Reads "<name attributes>" and returns the name and whether it carried type_id="opencv-matrix".
        auto open_tag = [&](bool& is_matrix) {
            if (at >= text.size() || text[at] != '<' || text.compare(at, 2, "</") == 0) fail(line, "expected an opening tag");
            const size_t end = text.find('>', at);
            if (end == std::string::npos) fail(line, "unclosed tag");
            const std::string inside = text.substr(at + 1, end - at - 1);
            const std::string name = inside.substr(0, inside.find_first_of(" \t\r\n"));
            if (!is_key(name)) fail(line, "'" + name.substr(0, 32) + "' is not a valid element name");
            is_matrix = inside.find("opencv-matrix") != std::string::npos;
            advance_to(end + 1);
            return name;
        };
        auto element_text = [&](const std::string& name) {
            const std::string closing = "</" + name + ">";
            const size_t end = text.find(closing, at);
            if (end == std::string::npos) fail(line, "element <" + name + "> is not closed");
            const std::string inside = text.substr(at, end - at);
            if (inside.find('<') != std::string::npos) fail(line, "element <" + name + "> must hold text only");
            advance_to(end + closing.size());
            return inside;
        };

        skip_space_and_comments();
        bool ignored;
        if (open_tag(ignored) != "opencv_storage") fail(line, "the root element must be <opencv_storage>");
        StorageEntries entries;
        while (true) {
            skip_space_and_comments();
            if (text.compare(at, 17, "</opencv_storage>") == 0) break;
            bool is_matrix = false;
            const int start_line = line;
            const std::string key = open_tag(is_matrix);
            if (entries.count(key)) fail(start_line, "'" + key + "' appears twice");
            StorageValue value;
            value.line = start_line;
            if (is_matrix) {
                value.kind = StorageValue::Kind::Matrix;
                bool has_rows = false, has_cols = false, has_data = false;
                while (true) {
                    skip_space_and_comments();
                    if (text.compare(at, key.size() + 3, "</" + key + ">") == 0) {
                        advance_to(at + key.size() + 3);
                        break;
                    }
                    bool nested;
                    const int field_line = line;
                    const std::string field = open_tag(nested);
                    const std::string content = element_text(field);
                    if (field == "rows") value.rows = whole_number(trim(content), field_line, "rows"), has_rows = true;
                    else if (field == "cols") value.cols = whole_number(trim(content), field_line, "cols"), has_cols = true;
                    else if (field == "dt") continue;
                    else if (field == "data") append_numbers(content, field_line, value.numbers), has_data = true;
                    else fail(field_line, "unknown matrix field <" + field.substr(0, 32) + ">");
                }
                if (!has_rows || !has_cols || !has_data) fail(start_line, "'" + key + "' needs rows, cols and data");
                check_matrix(value, key);
            } else {
                const std::string content = trim(element_text(key));
                std::vector<double> numbers;
                bool all_numbers = !content.empty();
                try {
                    append_numbers(content, start_line, numbers);
                } catch (const Error&) {
                    all_numbers = false;
                }
                if (all_numbers && numbers.size() == 1) {
                    value.kind = StorageValue::Kind::Number;
                    value.numbers = numbers;
                } else if (all_numbers) {
                    value.kind = StorageValue::Kind::List;
                    value.numbers = numbers;
                } else {
                    value.kind = StorageValue::Kind::Word;
                    value.word = content;
                }
            }
            entries[key] = std::move(value);
        }
        return entries;
    }

    // OpenCV's JSON: one object of "key": value, where a value is a number, a string, a list
    // of numbers or a matrix object; nothing nests deeper.
    StorageEntries parse_json(const std::string& text) const {
        size_t at = 0;
        int line = 1;
        auto skip_space = [&] {  // and the /* comments */ OpenCV writes into JSON
            while (at < text.size()) {
                if (text.compare(at, 2, "/*") == 0) {
                    const size_t end = text.find("*/", at + 2);
                    if (end == std::string::npos) fail(line, "unclosed comment");
                    line += int(std::count(text.begin() + long(at), text.begin() + long(end), '\n'));
                    at = end + 2;
                } else if (std::strchr(" \t\r\n", text[at]) && text[at] != '\0') {
                    line += text[at++] == '\n';
                } else {
                    return;
                }
            }
        };
        auto expect = [&](char wanted) {
            skip_space();
            if (at >= text.size() || text[at] != wanted) fail(line, std::string("expected '") + wanted + "'");
            ++at;
        };
        auto peek = [&] {
            skip_space();
            return at < text.size() ? text[at] : '\0';
        };
        auto string_value = [&] {
            expect('"');
            const size_t end = text.find_first_of("\"\\\n", at);
            if (end == std::string::npos || text[end] != '"') fail(line, "unclosed or escaped string");
            const std::string word = text.substr(at, end - at);
            at = end + 1;
            return word;
        };
        auto number_token = [&] {
            skip_space();
            const size_t end = text.find_first_of(",]} \t\r\n", at);
            const std::string token = text.substr(at, (end == std::string::npos ? text.size() : end) - at);
            at += token.size();
            return token;
        };
        auto number_list = [&](std::vector<double>& numbers) {
            expect('[');
            if (peek() == ']') {
                ++at;
                return;
            }
            while (true) {
                append_numbers(number_token(), line, numbers);
                if (peek() == ']') {
                    ++at;
                    return;
                }
                expect(',');
            }
        };
        // Calls `member(key)` for each "key": of an object, with `at` on the value.
        auto object = [&](const auto& member) {
            expect('{');
            if (peek() == '}') {
                ++at;
                return;
            }
            while (true) {
                const std::string key = string_value();
                expect(':');
                member(key);
                if (peek() == '}') {
                    ++at;
                    return;
                }
                expect(',');
            }
        };

        StorageEntries entries;
        object([&](const std::string& key) {
            if (!is_key(key)) fail(line, "'" + key.substr(0, 32) + "' is not a valid key");
            if (entries.count(key)) fail(line, "'" + key + "' appears twice");
            StorageValue value;
            value.line = line;
            const char first = peek();
            if (first == '"') {
                value.kind = StorageValue::Kind::Word;
                value.word = string_value();
            } else if (first == '[') {
                value.kind = StorageValue::Kind::List;
                number_list(value.numbers);
            } else if (first == '{') {
                value.kind = StorageValue::Kind::Matrix;
                bool is_matrix = false, has_rows = false, has_cols = false, has_data = false;
                object([&](const std::string& field) {
                    const int field_line = line;
                    if (field == "type_id") is_matrix = string_value() == "opencv-matrix";
                    else if (field == "rows") value.rows = whole_number(number_token(), field_line, "rows"), has_rows = true;
                    else if (field == "cols") value.cols = whole_number(number_token(), field_line, "cols"), has_cols = true;
                    else if (field == "dt") string_value();
                    else if (field == "data") number_list(value.numbers), has_data = true;
                    else fail(field_line, "unknown matrix field '" + field.substr(0, 32) + "'");
                });
                if (!is_matrix) fail(value.line, "'" + key + "' is a map that is not an opencv-matrix");
                if (!has_rows || !has_cols || !has_data) fail(value.line, "'" + key + "' needs rows, cols and data");
                check_matrix(value, key);
            } else {
                const std::string token = number_token();
                double parsed;
                if (!parse_number(token, parsed)) fail(line, "'" + key + "' has no valid value");
                value.kind = StorageValue::Kind::Number;
                value.numbers.push_back(parsed);
            }
            entries[key] = std::move(value);
        });
        skip_space();
        if (at != text.size()) fail(line, "text after the closing '}'");
        return entries;
    }

private:
    std::string path_;
};

}  // namespace

StorageEntries parse_storage_text(const std::string& text, const std::string& path) {
    const Parser parser(path);
    const size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos) throw Error(path, "file is empty");
    if (text[first] == '<') return parser.parse_xml(text);
    if (text[first] == '{') return parser.parse_json(text);
    return parser.parse_yaml(text);
}

int storage_format_for(const std::string& path) {
    std::string extension = path.substr(std::min(path.size(), path.find_last_of('.')));
    for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (extension == ".xml") return cv::FileStorage::FORMAT_XML;
    if (extension == ".json") return cv::FileStorage::FORMAT_JSON;
    return cv::FileStorage::FORMAT_YAML;
}

}  // namespace picoscan::detail
