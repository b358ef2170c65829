#pragma once

#include <cctype>
#include <string>
#include <string_view>
#include <vector>

namespace dg::io::testing {

// A small XML well-formedness check, independent of the writers: an optional
// declaration, comments, one root element, properly nested tags with quoted
// attributes, no '<' or bare '&' in text or values. Returns "" when the text
// is well-formed, else what is wrong and where (byte offset).
inline std::string XmlProblem(std::string_view xml) {
  const auto at = [](size_t pos) { return " at byte " + std::to_string(pos); };
  const auto is_name = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
           c == '.';
  };
  const auto text_problem = [&](size_t begin, size_t end, bool inside_root) -> std::string {
    for (size_t i = begin; i < end; ++i) {
      if (!inside_root && !std::isspace(static_cast<unsigned char>(xml[i]))) {
        return "text outside the root" + at(i);
      }
      if (xml[i] == '&') {
        const size_t semicolon = xml.find(';', i);
        if (semicolon == std::string_view::npos || semicolon > end || semicolon == i + 1) {
          return "bare &" + at(i);
        }
      }
    }
    return "";
  };
  std::vector<std::string_view> open;
  int roots = 0;
  size_t pos = 0;
  while (true) {
    const size_t lt = xml.find('<', pos);
    const size_t text_end = lt == std::string_view::npos ? xml.size() : lt;
    if (std::string problem = text_problem(pos, text_end, !open.empty()); !problem.empty()) {
      return problem;
    }
    if (lt == std::string_view::npos) break;
    if (xml.substr(lt, 2) == "<?" || xml.substr(lt, 4) == "<!--") {
      const std::string_view close = xml[lt + 1] == '?' ? "?>" : "-->";
      const size_t end = xml.find(close, lt);
      if (end == std::string_view::npos) return "unterminated declaration or comment" + at(lt);
      pos = end + close.size();
      continue;
    }
    size_t i = lt + 1;
    const bool closing = xml[i] == '/';
    if (closing) ++i;
    const size_t name_begin = i;
    while (i < xml.size() && is_name(xml[i])) ++i;
    const std::string_view name = xml.substr(name_begin, i - name_begin);
    if (name.empty()) return "tag without a name" + at(lt);
    if (closing) {
      while (i < xml.size() && std::isspace(static_cast<unsigned char>(xml[i]))) ++i;
      if (i >= xml.size() || xml[i] != '>') return "malformed closing tag" + at(lt);
      if (open.empty() || open.back() != name) {
        return "closing tag " + std::string(name) + " does not match" + at(lt);
      }
      open.pop_back();
      pos = i + 1;
      continue;
    }
    while (true) {
      while (i < xml.size() && std::isspace(static_cast<unsigned char>(xml[i]))) ++i;
      if (i >= xml.size()) return "unterminated tag" + at(lt);
      if (xml.substr(i, 2) == "/>" || xml[i] == '>') break;
      const size_t attribute = i;
      while (i < xml.size() && is_name(xml[i])) ++i;
      if (i == attribute || i + 1 >= xml.size() || xml[i] != '=' ||
          (xml[i + 1] != '"' && xml[i + 1] != '\'')) {
        return "malformed attribute" + at(attribute);
      }
      const size_t value_end = xml.find(xml[i + 1], i + 2);
      if (value_end == std::string_view::npos) {
        return "unterminated attribute value" + at(attribute);
      }
      if (xml.substr(i + 2, value_end - i - 2).find('<') != std::string_view::npos) {
        return "'<' in a value" + at(i);
      }
      if (std::string problem = text_problem(i + 2, value_end, true); !problem.empty()) {
        return problem;
      }
      i = value_end + 1;
    }
    if (open.empty() && ++roots > 1) return "more than one root element" + at(lt);
    if (xml[i] == '>') {
      open.push_back(name);
      pos = i + 1;
    } else {
      pos = i + 2;
    }
  }
  if (!open.empty()) return "unclosed element " + std::string(open.back());
  if (roots != 1) return "no root element";
  return "";
}

}  // namespace dg::io::testing
