// Small text helpers shared by the readers and the CLI: "did you mean" suggestions.
#pragma once
#include <algorithm>
#include <string>
#include <vector>

namespace aniso {

// Levenshtein distance between two short strings.
inline size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> d(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t prev = d[0];
    d[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t cur = d[j];
      d[j] = std::min({d[j] + 1, d[j - 1] + 1, prev + (a[i - 1] == b[j - 1] ? 0 : 1)});
      prev = cur;
    }
  }
  return d[b.size()];
}

// The closest candidate within a small edit distance (about a third of the word), or "".
inline std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_d = std::max<size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    const size_t dist = edit_distance(word, c);
    if (dist < best_d) {
      best_d = dist;
      best = c;
    }
  }
  return best;
}

// " (did you mean 'x'?)" or "".
inline std::string did_you_mean(const std::string& word, const std::vector<std::string>& known) {
  const std::string c = closest(word, known);
  return c.empty() ? "" : " (did you mean '" + c + "'?)";
}

}  // namespace aniso
