// Shared by the GPU BIH build passes (core/bih/bih_gpu_build.c): the LBVH
// node numbering and the Karras inner-node record.
//
// Karras 2012 numbering: n sorted triangles give inner nodes 0..n-2 (root 0)
// and leaves n-1..2n-2 (leaf j of the sorted order is node n-1+j), so one
// index space covers parents, bounds and triangle counts.
#ifndef BIH_BUILD_GLSL
#define BIH_BUILD_GLSL

const uint BIH_BUILD_NO_PARENT = 0xFFFFFFFFu;
// Split axis not fixed by the codes (equal codes split by index): the
// bottom-up pass picks the longest axis of the node's box instead.
const uint BIH_BUILD_AXIS_UNDECIDED = 3u;

// Bound on the inner nodes on any leaf-to-root path of the Karras tree: each
// level lengthens the common key prefix by at least one bit, and keys are 30
// code bits (top 2 of 32 always zero, so the root's prefix is >= 2) followed
// by a 32-bit position, so prefixes run from 2 to 63: at most 62 levels.
const uint BIH_BUILD_LEVELS = 62u;

struct BihInner {
    uint left;   // child node numbers (inner or leaf, see above)
    uint right;
    uint first;  // first sorted triangle under this node (its range is contiguous)
    uint axis;   // 0..2, or BIH_BUILD_AXIS_UNDECIDED until the bottom-up pass
};

#endif
