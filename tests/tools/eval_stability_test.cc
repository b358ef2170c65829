// Tests of dynaguide eval stability (issue 9): being written.
