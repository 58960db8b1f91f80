// placeholder: BVH traversal (owned by the BVH work)
