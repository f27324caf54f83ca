#pragma once
// What the SVG plot tests share: a small XML well-formedness checker, path data read back into
// points, and sample data for the SLAM pictures.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "slamkit/plot/svg_plot.hpp"

namespace slamkit::plot::test_svg {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- A small XML well-formedness checker ------------------------------------------------------

inline bool valid_references(const std::string& s) {
  for (std::size_t at = s.find('&'); at != std::string::npos; at = s.find('&', at + 1)) {
    const std::size_t end = s.find(';', at);
    if (end == std::string::npos) return false;
    const std::string name = s.substr(at + 1, end - at - 1);
    const bool known = name == "amp" || name == "lt" || name == "gt" || name == "quot" || name == "apos" ||
                       (name.size() > 1 && name[0] == '#');
    if (!known) return false;
  }
  return true;
}

inline bool is_name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == ':' || c == '_';
}

/// Empty if `xml` is well-formed (one root, balanced tags, quoted unique attributes, valid entity
/// references, no raw '<' in text); otherwise what is wrong and where.
inline std::string xml_error(const std::string& xml) {
  std::vector<std::string> open;
  int roots = 0;
  std::size_t i = 0;
  if (xml.rfind("<?xml", 0) == 0) {
    i = xml.find("?>");
    if (i == std::string::npos) return "unterminated XML declaration";
    i += 2;
  }
  while (i < xml.size()) {
    const std::size_t lt = xml.find('<', i);
    const std::string text = xml.substr(i, lt == std::string::npos ? std::string::npos : lt - i);
    if (!valid_references(text)) return "bad reference in text near offset " + std::to_string(i);
    if (open.empty() && text.find_first_not_of(" \n\t\r") != std::string::npos)
      return "text outside the root element at offset " + std::to_string(i);
    if (lt == std::string::npos) break;
    const std::size_t gt = xml.find('>', lt);
    if (gt == std::string::npos) return "unterminated tag at offset " + std::to_string(lt);
    std::string tag = xml.substr(lt + 1, gt - lt - 1);
    i = gt + 1;
    if (tag.find('<') != std::string::npos) return "'<' inside a tag at offset " + std::to_string(lt);
    if (!tag.empty() && tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (open.empty() || open.back() != name)
        return "unbalanced </" + name + "> at offset " + std::to_string(lt);
      open.pop_back();
      continue;
    }
    const bool self_closing = !tag.empty() && tag.back() == '/';
    if (self_closing) tag.pop_back();
    std::size_t p = 0;
    while (p < tag.size() && is_name_char(tag[p])) ++p;
    const std::string name = tag.substr(0, p);
    if (name.empty()) return "tag without a name at offset " + std::to_string(lt);
    std::vector<std::string> attributes;
    while (true) {
      while (p < tag.size() && std::isspace(static_cast<unsigned char>(tag[p]))) ++p;
      if (p >= tag.size()) break;
      const std::size_t start = p;
      while (p < tag.size() && is_name_char(tag[p])) ++p;
      const std::string attribute = tag.substr(start, p - start);
      if (attribute.empty() || p + 1 >= tag.size() || tag[p] != '=' || tag[p + 1] != '"')
        return "malformed attribute in <" + name + "> at offset " + std::to_string(lt);
      const std::size_t close = tag.find('"', p + 2);
      if (close == std::string::npos) return "unterminated attribute value in <" + name + ">";
      if (!valid_references(tag.substr(p + 2, close - p - 2))) return "bad reference in <" + name + ">";
      if (std::find(attributes.begin(), attributes.end(), attribute) != attributes.end())
        return "duplicate attribute " + attribute + " in <" + name + ">";
      attributes.push_back(attribute);
      p = close + 1;
    }
    if (open.empty()) ++roots;
    if (!self_closing) open.push_back(name);
  }
  if (!open.empty()) return "unclosed <" + open.back() + ">";
  if (roots != 1) return std::to_string(roots) + " root elements";
  return {};
}

// ---- Reading paths back -------------------------------------------------------------------------

/// The d attributes of all <path> elements that follow an opening tag containing `marker` (the
/// group that carries a style) up to that group's end.
inline std::vector<std::string> paths_in_group(const std::string& svg, const std::string& marker) {
  std::vector<std::string> out;
  const std::size_t at = svg.find(marker);
  if (at == std::string::npos) return out;
  const std::size_t end = svg.find("</g>", at);
  for (std::size_t p = svg.find("<path d=\"", at); p != std::string::npos && p < end;
       p = svg.find("<path d=\"", p + 1)) {
    const std::size_t start = p + 9;
    out.push_back(svg.substr(start, svg.find('"', start) - start));
  }
  return out;
}

/// Subpaths of path data made of M (absolute) and l (relative, repeated pairs) commands, which is
/// what polylines and ellipses are written with.
inline std::vector<std::vector<Vector2>> parse_polyline_path(const std::string& d) {
  std::vector<std::vector<Vector2>> pieces;
  std::istringstream in(d);
  char command = 0;
  Vector2 current = Vector2::Zero();
  while (in >> std::ws && in.peek() != EOF) {
    if (std::isalpha(in.peek())) in >> command;
    double x = 0, y = 0;
    if (!(in >> x >> y)) {
      ADD_FAILURE() << "unparsable path data: " << d;
      return pieces;
    }
    if (command == 'M') {
      current = Vector2(x, y);
      pieces.push_back({current});
    } else if (command == 'l' && !pieces.empty()) {
      current += Vector2(x, y);
      pieces.back().push_back(current);
    } else {
      ADD_FAILURE() << "unexpected path command '" << command << "' in " << d;
      return pieces;
    }
  }
  return pieces;
}

inline std::size_t count(const std::string& haystack, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t p = haystack.find(needle); p != std::string::npos; p = haystack.find(needle, p + 1)) ++n;
  return n;
}

inline std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// 1, 2 or 5 times a power of ten.
inline bool is_125(double step) {
  const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
  return std::abs(mantissa - 1) < 1e-6 || std::abs(mantissa - 2) < 1e-6 || std::abs(mantissa - 5) < 1e-6;
}

inline MapPlotData sample_map() {
  MapPlotData m;
  m.title = "EKF-SLAM map";
  m.subtitle = "ATE 0.4 m";
  for (int i = 0; i <= 200; ++i) {
    const double a = 2 * std::numbers::pi * i / 200;
    m.true_trajectory.emplace_back(30 * std::cos(a), 12 * std::sin(a));
    m.estimated_trajectory.emplace_back(30.3 * std::cos(a), 12.2 * std::sin(a));
    m.dead_reckoning.emplace_back(31 * std::cos(a) + 0.01 * i, 13 * std::sin(a));
  }
  m.reference_points = {{30, 0}, {0, 12}, {-30, 0}};
  for (int k = 0; k < 10; ++k) {
    Landmark l;
    l.id = k;
    l.position = Vector2(-25 + 5.0 * k, k % 2 ? 18 : -18);
    m.true_landmarks.push_back(l);
    l.position += Vector2(0.3, -0.2);
    l.covariance << 0.2, 0.05, 0.05, 0.1;
    m.estimated_landmarks.push_back(l);
  }
  return m;
}

inline StdPlotData sample_std(int landmarks) {
  StdPlotData d;
  d.title = "landmark uncertainty";
  for (int k = 0; k < landmarks; ++k) {
    StdSeries s;
    s.id = k;
    for (int i = 0; i < 300; ++i) {
      const double t = 0.1 * i;
      s.t.push_back(t);
      const double v = t < 0.05 * k ? kNaN : 2.0 / (1.0 + t) + 0.01;
      s.std_x.push_back(v);
      s.std_y.push_back(0.5 * v);
    }
    d.series.push_back(s);
  }
  return d;
}

}  // namespace slamkit::plot::test_svg
