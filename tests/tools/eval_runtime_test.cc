// Tests of dynaguide eval runtime (issue 9): being written.
