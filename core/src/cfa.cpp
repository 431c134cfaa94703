#include "paintlab/core/cfa.h"

#include "paintlab/core/enum_names.h"

namespace paintlab {

constexpr EnumNames<CfaPattern, 5> kCfaNames{{
    {CfaPattern::None, "none"}, {CfaPattern::RG, "RG"}, {CfaPattern::GR, "GR"}, {CfaPattern::GB, "GB"}, {CfaPattern::BG, "BG"},
}};

const char* to_string(CfaPattern p) { return enum_name(kCfaNames, p, "none"); }

CfaPattern cfa_pattern_from_string(const std::string& name, const std::string& where) {
  return enum_from_name(kCfaNames, name, "colour-filter arrangement", where);
}

int cfa_colour(CfaPattern p, int x, int y) {
  // The top-left 2x2 block, row by row, as colour indices.
  static constexpr int kBlocks[5][4] = {{-1, -1, -1, -1}, {0, 1, 1, 2}, {1, 0, 2, 1}, {1, 2, 0, 1}, {2, 1, 1, 0}};
  return kBlocks[static_cast<int>(p)][2 * (y & 1) + (x & 1)];
}

}  // namespace paintlab
