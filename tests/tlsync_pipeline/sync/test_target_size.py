"""The target's size in metres among merged blobs and fragments, and its part of a merged blob."""

import numpy as np

from tlsync_pipeline.sync.identify.target_size import reference_size, target_within


def test_the_reference_size_is_the_target_alone_among_merged_blobs_and_fragments():
    rng = np.random.default_rng(0)
    alone = np.column_stack([rng.uniform(0.48, 0.55, 15), rng.uniform(1.6, 1.75, 15)])
    merged = np.column_stack(
        [rng.uniform(1.2, 1.8, 60), rng.uniform(1.6, 1.9, 60)]
    )  # 3 in 4 blobs merged side by side with passers-by
    fragments = np.column_stack([rng.uniform(0.05, 0.2, 10), rng.uniform(0.1, 0.4, 10)])  # bits seen between occluders
    reference = reference_size(np.vstack([alone, merged, fragments]))
    assert np.allclose(reference, [0.5, 1.68], rtol=0.1), reference
    assert reference_size(alone[:5]) is None


def test_the_target_is_the_part_of_a_merged_blob_nearest_the_projection():
    xy = np.array([[100.0, 100.0], [100.0, 100.0], [50.0, 50.0]])
    box = np.array([[60.0, 100.0], [60.0, 100.0], [20.0, 50.0]])
    slack = np.array(
        [[20.0, 0.0], [20.0, 0.0], [0.0, 0.0]]
    )  # 20 px either side across the merged blob; none on the lone target
    offset = np.array(
        [[-30.0, 4.0], [5.0, -3.0], [3.0, 2.0]]
    )  # projection beyond the slack, inside it, and on a blob of the target's size
    centre, size = target_within(xy, box, offset, slack)
    assert centre.tolist() == [[80.0, 100.0], [105.0, 100.0], [50.0, 50.0]]
    assert size.tolist() == [[20.0, 100.0], [20.0, 100.0], [20.0, 50.0]]
    kept, _ = target_within(xy[:1], box[:1], np.array([[np.inf, np.inf]]), slack[:1])
    assert kept.tolist() == [[100.0, 100.0]]
