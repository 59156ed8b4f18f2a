// pipetile — `pipetile bench`: the paper's Table 1 and the peers a user would pick instead.
#pragma once

#include <string>

namespace pipetile::tools {

struct BenchArgs {
    std::string input;  // empty: the bundled phantom
    std::string report; // JSON output, or empty
    std::string html;   // HTML report, or empty
    int repeat = 5;     // repetitions per figure; the median is reported, with min and max
    int threads = 0;
    std::string owner; // who writes the report (the command line), for a concurrent run's message
};

/// Runs the benchmark, prints Markdown tables, writes the JSON report. @throw Error as the library.
int runBench(const BenchArgs& args);

} // namespace pipetile::tools
