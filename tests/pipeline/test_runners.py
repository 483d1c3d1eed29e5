"""The runners of independent tasks (``pipeline.runners``): each gives the serial results, ``map`` in order and
``completed`` every result once; a shared value stands in for its argument."""

import operator

from pipeline.runners import SERIAL, on_this_machine, process_pool

TASKS = [(number, 10 * number) for number in range(7)]


def test_a_process_pool_gives_the_serial_results():
    serial = SERIAL.map(operator.add, TASKS)
    assert serial == [11 * number for number in range(7)]
    assert sorted(SERIAL.completed(operator.add, TASKS)) == serial
    with process_pool(2) as runner:
        assert runner.slots == 2
        shared = runner.share(3)
        assert runner.map(operator.mul, [(shared, number) for number in range(5)]) == [0, 3, 6, 9, 12]
        assert runner.map(operator.add, TASKS) == serial
        assert sorted(runner.completed(operator.add, TASKS)) == serial


def test_only_a_remote_scheduler_evaluates_elsewhere():
    """None, empty and ``local`` run on this machine (in this process, or a LocalCluster); an address does not."""
    assert on_this_machine(None) and on_this_machine("") and on_this_machine("local")
    assert not on_this_machine("tcp://10.0.0.2:8786")
