//! Runway-mapping exploration, pure: the lawnmower sweep and the multi-robot recursive DFS of
//! the runway paper (Algorithm 1).
