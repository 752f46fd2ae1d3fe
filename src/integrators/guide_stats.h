// What a guided render's path guide costs (path_guide.h), as RenderStats and --stats report it.
#pragma once

#include <cstdint>
#include <vector>

namespace cierzo {

// What the guide costs (--stats' "guiding").
struct GuideStats {
    uint32_t cells = 0;                       // cells of the guide sampled now
    uint64_t nodes = 0;                       // its quadtree nodes
    uint64_t learning_nodes = 0;              // the learning trees' nodes
    uint64_t bytes = 0;                       // the memory both take
    uint64_t record_table_bytes = 0;          // wavefront: the largest thread's table of records
    uint64_t records = 0;                     // vertices deposited, in all iterations
    bool learning = true;                     // whether the paths still record (PathGuide)
    std::vector<uint32_t> cells_by_fraction;  // cells of each share α (kGuideFractions)
    std::vector<double> training_seconds;     // each training's (one per iteration)
    std::vector<int64_t> trained_at;          // the paths per pixel each training came after
};

}  // namespace cierzo
