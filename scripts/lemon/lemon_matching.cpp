// Benchmark peer: LEMON's MaxWeightedPerfectMatching on a blossomquad matching graph file
// (first line "n m", then m lines "u v cost", 0-based). Minimum cost = maximum of negated
// costs; fractionalInit() is LEMON's fastest start. Prints one line like solve_matching.
// Build: scripts/lemon/build.sh
#include <lemon/matching.h>
#include <lemon/smart_graph.h>
#include <chrono>
#include <cstdio>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lemon_matching <graph-file>\n");
    return 2;
  }
  std::FILE* f = std::fopen(argv[1], "r");
  if (!f) {
    std::perror(argv[1]);
    return 2;
  }
  long long n = 0, m = 0;
  if (std::fscanf(f, "%lld %lld", &n, &m) != 2) {
    std::fprintf(stderr, "%s: bad header\n", argv[1]);
    return 2;
  }
  lemon::SmartGraph g;
  g.reserveNode(n);
  g.reserveEdge(m);
  std::vector<lemon::SmartGraph::Node> nodes(n);
  for (long long i = 0; i < n; ++i) nodes[i] = g.addNode();
  lemon::SmartGraph::EdgeMap<long long> w(g);
  std::vector<std::pair<lemon::SmartGraph::Edge, long long>> ecost;
  ecost.reserve(m);
  for (long long i = 0; i < m; ++i) {
    long long u, v, c;
    if (std::fscanf(f, "%lld %lld %lld", &u, &v, &c) != 3 || u < 0 || v < 0 || u >= n || v >= n) {
      std::fprintf(stderr, "%s: bad edge %lld\n", argv[1], i);
      return 2;
    }
    ecost.push_back({g.addEdge(nodes[u], nodes[v]), c});
  }
  std::fclose(f);
  for (auto& ec : ecost) w[ec.first] = -ec.second;
  auto t0 = std::chrono::steady_clock::now();
  lemon::MaxWeightedPerfectMatching<lemon::SmartGraph, lemon::SmartGraph::EdgeMap<long long>> mwpm(g, w);
  mwpm.fractionalInit();
  bool ok = mwpm.start();
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!ok) {
    std::printf("n=%lld m=%lld no_perfect_matching time_s=%.3f\n", n, m, secs);
    return 1;
  }
  std::printf("n=%lld m=%lld cost=%lld time_s=%.3f\n", n, m, -(long long)mwpm.matchingWeight(), secs);
  return 0;
}
