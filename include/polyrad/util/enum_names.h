// Names of enum values, one table per enum, declared beside the enum: what the command line
// accepts, what reports and file headers write, and what they read back. An unknown name is an
// InputError listing the known ones, never a silent default.
//
//   enum class Colour { kRed, kBlue };
//   template <> struct EnumNames<Colour> {
//     static constexpr const char* kind = "colour";
//     static constexpr std::array<std::pair<Colour, const char*>, 2> table{
//         {{Colour::kRed, "red"}, {Colour::kBlue, "blue"}}};
//   };
//   enum_name(Colour::kRed);            // "red"
//   enum_from_name<Colour>("blue");     // Colour::kBlue; "green" throws InputError
//
// Cost: a linear search of a few entries.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "polyrad/util/error.h"

namespace polyrad {

template <typename E>
struct EnumNames;  // specialised beside each named enum

template <typename E>
const char* enum_name(E value) {
  for (const auto& [v, name] : EnumNames<E>::table)
    if (v == value) return name;
  check_failed("the value has a name in its EnumNames table", __FILE__, __LINE__);
}

template <typename E>
std::vector<std::string> enum_names() {
  std::vector<std::string> names;
  for (const auto& entry : EnumNames<E>::table) names.emplace_back(entry.second);
  return names;
}

// Throws InputError naming the kind, the unknown name and the known ones.
template <typename E>
E enum_from_name(std::string_view name) {
  for (const auto& [v, n] : EnumNames<E>::table)
    if (name == n) return v;
  std::string known;
  for (const auto& entry : EnumNames<E>::table)
    known += (known.empty() ? "" : ", ") + std::string(entry.second);
  throw InputError("unknown " + std::string(EnumNames<E>::kind) + " '" + std::string(name) +
                   "' (one of: " + known + ")");
}

}  // namespace polyrad
